/// @file request_parser.hpp
/// Parses a request payload (`L[1]`, `M[16,"Shutdown"]`) into an opcode, up to 12 int16 arguments and at
/// most one string, with the reference's message-parser error codes (-8..-14). Used by Tether firmware
/// after the envelope decoder delivered a frame; portable, no allocation.
#pragma once

#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/romi/errors.hpp"
#include "tether/romi/limits.hpp"

namespace tether {
namespace romi {

/// A parsed request whose string argument stays where it was parsed: a view of its characters in the
/// payload (between its quotes, not NUL-terminated). What a device keeps: the string is in its frame
/// buffer already, and a copy would be 33 more bytes of RAM (RomiSerial terminates it in place).
struct ParsedRequest {
  char opcode = 0;                        ///< [a-zA-Z0-9?].
  uint8_t argument_count = 0;             ///< Integer arguments in `arguments`.
  int16_t arguments[kMaxArguments] = {};  ///< The integers, in order (a string does not count).
  bool has_string = false;                ///< A string argument was given.
  /// The string's characters in the payload (at most `kMaxStringLength`; empty when there is none).
  /// Valid while the payload is.
  ByteView string_view;
};

/// A parsed request with its own copy of the string: independent of the payload.
struct Request : ParsedRequest {
  char string[kMaxStringLength + 1] = {};  ///< The string, NUL-terminated (handlers get a C string).
};

/// Parses `payload` into `request`, which is default-constructed or the result of an earlier parse (its
/// `argument_count` tells which arguments to clear: every argument past the parsed ones is 0). Returns
/// no_error, or -14 (bad opcode), -8 (unexpected character), -9 (more than 12 integers), -10 (outside
/// int16), -11 (string over 32), -12 (bad string character or unterminated string), -13 (second string).
Error parse_request(ByteView payload, ParsedRequest& request);
/// As above, and on an error sets `error_offset` to where in `payload` it was found: the offending
/// character, the first character of a number out of range or one too many, the opening quote of a string
/// too long or too many, `payload.size()` when the payload ends too early. For messages to a person (the
/// host); the device's form keeps no offset.
Error parse_request(ByteView payload, ParsedRequest& request, size_t& error_offset);
/// As above, and copies the string into `request.string` ("" when there is none).
Error parse_request(ByteView payload, Request& request);

}  // namespace romi
}  // namespace tether
