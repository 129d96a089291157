#include "tether/romi/request_parser.hpp"

#include "tether/romi/encoder.hpp"

namespace tether {
namespace romi {

namespace {

// Where parsing stopped, for the host's messages; the device's parse keeps nothing (the empty sink
// inlines to no code).
struct NoOffset {
  void at(size_t) {}
};
struct Offset {
  size_t& where;
  void at(size_t i) { where = i; }
};

template <typename Sink>
inline Error parse(ByteView payload, ParsedRequest& request, Sink sink) __attribute__((always_inline));

template <typename Sink>
inline Error parse(ByteView payload, ParsedRequest& request, Sink sink) {
  // Not `request = ParsedRequest()`: unused arguments stay 0: only those the last parse set can be other
  // than 0 (a request starts all zero), so only they are cleared (none after a request without
  // arguments: 12 stores fewer per request on the device).
  int16_t* argument = request.arguments;
  const uint8_t stale = request.argument_count < kMaxArguments ? request.argument_count : kMaxArguments;
  for (uint8_t left = stale; left != 0; --left) *argument++ = 0;  // an 8-bit count
  request.opcode = 0;
  request.argument_count = 0;
  request.has_string = false;
  request.string_view = ByteView();
  sink.at(0);
  if (payload.empty() || !is_opcode(payload[0])) return Error::invalid_opcode;
  request.opcode = static_cast<char>(payload[0]);
  if (payload.size() == 1) return Error::no_error;
  sink.at(1);
  if (payload[1] != '[') return Error::unexpected_char;
  size_t i = 2;
  if (i < payload.size() && payload[i] == ']') {  // "a[]": no arguments
    sink.at(i + 1);
    return i + 1 == payload.size() ? Error::no_error : Error::unexpected_char;
  }
  for (;;) {
    if (i >= payload.size()) {  // unterminated list
      sink.at(i);
      return Error::unexpected_char;
    }
    const uint8_t c = payload[i];
    if (c == '"') {
      if (request.has_string) {
        sink.at(i);
        return Error::too_many_strings;
      }
      sink.at(i);  // a string's errors point at its opening quote, but for a bad or missing character
      const uint8_t* const string = payload.data() + ++i;
      uint8_t length = 0;  // 8 bits: the AVR's loop counts in one register
      for (;;) {
        if (i >= payload.size()) {  // unterminated string
          sink.at(i);
          return Error::invalid_string;
        }
        const uint8_t s = payload[i];
        if (s == '"') break;
        if (length == kMaxStringLength) return Error::string_too_long;
        if (!is_string_char(s)) {
          sink.at(i);
          return Error::invalid_string;
        }
        ++length;
        ++i;
      }
      request.string_view = ByteView(string, length);
      request.has_string = true;
      ++i;  // the closing '"'
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      sink.at(i);  // a number's errors point at its first character, but for a missing digit
      const bool negative = c == '-';
      if (negative) ++i;
      if (i >= payload.size() || payload[i] < '0' || payload[i] > '9') {
        sink.at(i);
        return Error::unexpected_char;
      }
      // 16-bit magnitude (the AVR multiplies 32-bit numbers in a library call): more than 32768 is out
      // of range for either sign, and checking before the multiply keeps it from wrapping.
      uint16_t magnitude = 0;
      while (i < payload.size() && payload[i] >= '0' && payload[i] <= '9') {
        if (magnitude > 3276) return Error::value_out_of_range;  // the next digit makes it >= 32770
        magnitude = static_cast<uint16_t>(magnitude * 10u + static_cast<uint8_t>(payload[i] - '0'));
        if (magnitude > 32768) return Error::value_out_of_range;
        ++i;
      }
      if (magnitude > (negative ? 32768u : 32767u)) return Error::value_out_of_range;
      if (request.argument_count == kMaxArguments) return Error::too_many_arguments;
      request.arguments[request.argument_count++] =
          negative ? static_cast<int16_t>(-static_cast<int32_t>(magnitude)) : static_cast<int16_t>(magnitude);
    } else {
      sink.at(i);
      return Error::unexpected_char;
    }
    if (i >= payload.size()) {
      sink.at(i);
      return Error::unexpected_char;
    }
    if (payload[i] == ']') {
      sink.at(i + 1);
      return i + 1 == payload.size() ? Error::no_error : Error::unexpected_char;
    }
    if (payload[i] != ',') {
      sink.at(i);
      return Error::unexpected_char;
    }
    ++i;
  }
}

}  // namespace

Error parse_request(ByteView payload, ParsedRequest& request) { return parse(payload, request, NoOffset()); }

Error parse_request(ByteView payload, ParsedRequest& request, size_t& error_offset) {
  return parse(payload, request, Offset{error_offset});
}

Error parse_request(ByteView payload, Request& request) {
  // The string's buffer is a C string: only the bytes the string takes and its NUL are written.
  const Error error = parse_request(payload, static_cast<ParsedRequest&>(request));
  const ByteView string = request.string_view;
  for (size_t i = 0; i < string.size(); ++i) request.string[i] = static_cast<char>(string[i]);
  request.string[string.size()] = '\0';
  return error;
}

}  // namespace romi
}  // namespace tether
