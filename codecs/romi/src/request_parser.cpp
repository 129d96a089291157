#include "tether/romi/request_parser.hpp"

#include "tether/romi/encoder.hpp"

namespace tether {
namespace romi {

Error parse_request(ByteView payload, Request& request) {
  request = Request();
  if (payload.empty() || !is_opcode(payload[0])) return Error::invalid_opcode;
  request.opcode = static_cast<char>(payload[0]);
  if (payload.size() == 1) return Error::no_error;
  if (payload[1] != '[') return Error::unexpected_char;
  size_t i = 2;
  if (i < payload.size() && payload[i] == ']') {  // "a[]": no arguments
    return i + 1 == payload.size() ? Error::no_error : Error::unexpected_char;
  }
  for (;;) {
    if (i >= payload.size()) return Error::unexpected_char;  // unterminated list
    const uint8_t c = payload[i];
    if (c == '"') {
      if (request.has_string) return Error::too_many_strings;
      ++i;
      uint8_t length = 0;
      for (;;) {
        if (i >= payload.size()) return Error::invalid_string;  // unterminated string
        const uint8_t s = payload[i++];
        if (s == '"') break;
        if (length == kMaxStringLength) return Error::string_too_long;
        if (!is_string_char(s)) return Error::invalid_string;
        request.string[length++] = static_cast<char>(s);
      }
      request.string[length] = '\0';
      request.has_string = true;
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      const bool negative = c == '-';
      if (negative) ++i;
      if (i >= payload.size() || payload[i] < '0' || payload[i] > '9') return Error::unexpected_char;
      int32_t value = 0;
      while (i < payload.size() && payload[i] >= '0' && payload[i] <= '9') {
        value = value * 10 + (payload[i] - '0');
        if (value > 32768) return Error::value_out_of_range;  // stop before int32 could overflow
        ++i;
      }
      if (negative) value = -value;
      if (value < -32768 || value > 32767) return Error::value_out_of_range;
      if (request.argument_count == kMaxArguments) return Error::too_many_arguments;
      request.arguments[request.argument_count++] = static_cast<int16_t>(value);
    } else {
      return Error::unexpected_char;
    }
    if (i >= payload.size()) return Error::unexpected_char;
    if (payload[i] == ']') return i + 1 == payload.size() ? Error::no_error : Error::unexpected_char;
    if (payload[i] != ',') return Error::unexpected_char;
    ++i;
  }
}

}  // namespace romi
}  // namespace tether
