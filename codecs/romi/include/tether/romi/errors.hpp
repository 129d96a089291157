/// @file errors.hpp
/// Romi error codes: the reference numbering (RomiSerial), kept as is, plus Tether's own codes.
///
/// A response carries its code as the first value: 0 is success, positive codes belong to the
/// application, negative codes to the protocol. -1..-7 come from the envelope parser, -8..-14 from the
/// message parser, -15..-20 from the device dispatcher, -21..-28 from the host client. Tether adds codes
/// at -30 and below and never reuses a reference code.
///
/// | code | name | raised by |
/// |---|---|---|
/// | -30 | controller timeout: request not completed within 1 s | Tether firmware (reference defect B7) |
/// | -31 | reply too long for the device's output buffer | Tether firmware |
/// | -32 | string argument contains a reserved character (`#`, `:`, `"`, CR, LF) | Tether host (before sending) |
/// | -33 | transport error (port closed, device vanished) | Tether host |
#pragma once

#include <stdint.h>

namespace tether {
namespace romi {

/// Every protocol code. Values are the wire values (a response's first value); positive values, which
/// belong to the application, are valid `Error` values too.
enum class Error : int16_t {
  no_error = 0,
  envelope_too_long = -1,
  invalid_id = -2,
  invalid_crc = -3,
  crc_mismatch = -4,
  expected_end = -5,
  missing_metadata = -6,
  invalid_dummy_metadata = -7,
  unexpected_char = -8,
  too_many_arguments = -9,
  value_out_of_range = -10,
  string_too_long = -11,
  invalid_string = -12,
  too_many_strings = -13,
  invalid_opcode = -14,
  duplicate_message = -15,
  unknown_opcode = -16,
  bad_number_of_arguments = -17,
  missing_string = -18,
  bad_string = -19,
  no_reply = -20,
  client_invalid_opcode = -21,
  client_request_too_long = -22,
  client_empty_response = -23,
  client_empty_request = -24,
  client_timeout = -25,
  client_invalid_json = -26,
  client_bad_response = -27,
  client_invalid_error_response = -28,
  controller_timeout = -30,
  reply_too_long = -31,
  reserved_character = -32,
  transport_error = -33,
};

/// English text of `error` (the reference's wording where it has one, except -25: "client: no reply
/// from the device", which says what timed out, where the reference says "connection timed out");
/// "application error" for positive codes, "unknown error" for unassigned negative ones. Never null.
const char* describe(Error error);
/// The text of a response's code as it came off the wire: `describe(static_cast<Error>(code))`.
inline const char* describe(int16_t code) { return describe(static_cast<Error>(code)); }

/// Envelope errors -1..-6: the frame was damaged on the way, so re-sending the same bytes can help.
/// (The reference host retries exactly these; -7 needs a human to fix the typed command.)
inline bool is_envelope_error(int16_t code) { return code <= -1 && code >= -6; }


}  // namespace romi
}  // namespace tether
