#include "tether/romi/errors.hpp"

namespace tether {
namespace romi {

const char* describe(Error error) {
  if (static_cast<int16_t>(error) > 0) return "application error";
  switch (error) {
    case Error::no_error: return "no error";
    case Error::envelope_too_long: return "envelope too long";
    case Error::invalid_id: return "invalid id";
    case Error::invalid_crc: return "invalid crc";
    case Error::crc_mismatch: return "crc mismatch";
    case Error::expected_end: return "expected end of envelope";
    case Error::missing_metadata: return "missing metadata";
    case Error::invalid_dummy_metadata: return "invalid dummy metadata";
    case Error::unexpected_char: return "unexpected char";
    case Error::too_many_arguments: return "too many arguments";
    case Error::value_out_of_range: return "value out of range";
    case Error::string_too_long: return "string too long";
    case Error::invalid_string: return "invalid string";
    case Error::too_many_strings: return "too many strings";
    case Error::invalid_opcode: return "invalid opcode";
    case Error::duplicate_message: return "duplicate message";
    case Error::unknown_opcode: return "unknown opcode";
    case Error::bad_number_of_arguments: return "bad number of arguments";
    case Error::missing_string: return "missing string argument";
    case Error::bad_string: return "bad string argument";
    case Error::no_reply: return "handler sent no reply";
    case Error::client_invalid_opcode: return "client: invalid opcode";
    case Error::client_request_too_long: return "client: request too long";
    case Error::client_empty_response: return "client: empty response";
    case Error::client_empty_request: return "client: empty request";
    case Error::client_timeout: return "client: no reply from the device";
    case Error::client_invalid_json: return "client: invalid JSON";
    case Error::client_bad_response: return "client: badly formed response";
    case Error::client_invalid_error_response: return "client: invalid error response";
    case Error::controller_timeout: return "controller timeout: request not completed within 1 s";
    case Error::reply_too_long: return "reply too long for the device's buffer";
    case Error::reserved_character: return "string contains a reserved character (# : \" CR LF)";
    case Error::transport_error: return "transport error";
  }
  return "unknown error";
}

}  // namespace romi
}  // namespace tether
