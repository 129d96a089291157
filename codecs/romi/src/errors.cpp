#include "tether/romi/errors.hpp"

namespace tether {
namespace romi {

const char* message(int16_t code) {
  if (code > 0) return "application error";
  switch (static_cast<ErrorCode>(code)) {
    case ErrorCode::no_error: return "no error";
    case ErrorCode::envelope_too_long: return "envelope too long";
    case ErrorCode::invalid_id: return "invalid id";
    case ErrorCode::invalid_crc: return "invalid crc";
    case ErrorCode::crc_mismatch: return "crc mismatch";
    case ErrorCode::expected_end: return "expected end of envelope";
    case ErrorCode::missing_metadata: return "missing metadata";
    case ErrorCode::invalid_dummy_metadata: return "invalid dummy metadata";
    case ErrorCode::unexpected_char: return "unexpected char";
    case ErrorCode::too_many_arguments: return "too many arguments";
    case ErrorCode::value_out_of_range: return "value out of range";
    case ErrorCode::string_too_long: return "string too long";
    case ErrorCode::invalid_string: return "invalid string";
    case ErrorCode::too_many_strings: return "too many strings";
    case ErrorCode::invalid_opcode: return "invalid opcode";
    case ErrorCode::duplicate_message: return "duplicate message";
    case ErrorCode::unknown_opcode: return "unknown opcode";
    case ErrorCode::bad_number_of_arguments: return "bad number of arguments";
    case ErrorCode::missing_string: return "missing string argument";
    case ErrorCode::bad_string: return "bad string argument";
    case ErrorCode::no_reply: return "handler sent no reply";
    case ErrorCode::client_invalid_opcode: return "client: invalid opcode";
    case ErrorCode::client_request_too_long: return "client: request too long";
    case ErrorCode::client_empty_response: return "client: empty response";
    case ErrorCode::client_empty_request: return "client: empty request";
    case ErrorCode::client_timeout: return "client: no reply from the device";
    case ErrorCode::client_invalid_json: return "client: invalid JSON";
    case ErrorCode::client_bad_response: return "client: badly formed response";
    case ErrorCode::client_invalid_error_response: return "client: invalid error response";
    case ErrorCode::controller_timeout: return "controller timeout: request not completed within 1 s";
    case ErrorCode::reply_too_long: return "reply too long for the device's buffer";
    case ErrorCode::reserved_character: return "string contains a reserved character (# : \" CR LF)";
    case ErrorCode::transport_error: return "transport error";
  }
  return "unknown error";
}

}  // namespace romi
}  // namespace tether
