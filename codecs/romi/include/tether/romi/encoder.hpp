/// @file encoder.hpp
/// Romi frame writers: requests (host), responses and log lines (device), and a validating request
/// builder. All write into a caller's buffer and return the frame length or `Status::buffer_too_small`.
///
/// Frames, byte for byte as RomiSerial writes them:
///   request   `#` payload `:` id crc `\r\n`     payload = opcode [ `[` args `]` ], e.g. `#a[1,2,3]:00dd\r\n`
///   manual    `#` payload `:xxxx\r\n`            no id, CRC not checked (typed in a terminal)
///   response  `#` opcode `[` code (`,` value)* `]` `:` id crc `\r\n`   e.g. `#e[0,1,2]:00dc\r\n`
///   log       `#!` text `:xxxx\r\n`
/// id and crc are two lowercase hex digits each; crc is CRC-8/SMBUS over every byte from `#` through the id.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/status.hpp"
#include "tether/romi/errors.hpp"
#include "tether/romi/limits.hpp"

namespace tether {
namespace romi {

/// Writes a request frame for `payload` with `id`. `payload` is not checked (see RequestBuilder).
Result<size_t> encode_request(ByteView payload, uint8_t id, MutableByteView out);
/// Writes a manual request frame (`:xxxx`) for `payload`.
Result<size_t> encode_manual_request(ByteView payload, MutableByteView out);
/// Writes a response frame: `opcode`, then `body` (the bracketed array text, e.g. `[0,1,2]`), then the
/// metadata. Every ':' in `body` is written as '-' (the reference does the same: ':' ends the payload).
Result<size_t> encode_response(char opcode, ByteView body, uint8_t id, MutableByteView out);

/// Bytes a response frame adds to its body: '#', the opcode, ':', id, CRC, "\r\n". A frame always
/// starts with '#': a device may send that byte before it forms the rest (the reply's turnaround).
constexpr size_t kResponseOverhead = 9;

/// The upper four bits of `value` (0..15). On the AVR one SWAP: -Os shifts a promoted int by 4 in a loop.
__attribute__((always_inline)) inline uint8_t high_nibble(uint8_t value) {
#if defined(__AVR__)
  return static_cast<uint8_t>(__builtin_avr_swap(value) & 0x0F);
#else
  return static_cast<uint8_t>(value >> 4);
#endif
}

/// Lowercase hex digit of `nibble` (0..15), without a table in RAM.
__attribute__((always_inline)) inline uint8_t hex_digit(uint8_t nibble) {
  return static_cast<uint8_t>(nibble < 10 ? '0' + nibble : 'a' - 10 + nibble);
}

/// Stores `value` at `out` and steps `out` past it. On the AVR a post-increment store: avr-gcc addressed
/// each byte of a response's tail from one pointer with an add and a subtract around the store (4 cycles
/// a byte more).
__attribute__((always_inline)) inline void put_byte(uint8_t*& out, uint8_t value) {
#if defined(__AVR__)
  __asm__ volatile("st %a[out]+, %[value]" : [out] "+e"(out) : [value] "r"(value) : "memory");
#else
  *out++ = value;
#endif
}

/// Writes the response frame of `opcode`, the `size` bytes of `body` and `id` into `out`, which must
/// have room for `size + kResponseOverhead` bytes (not checked: the caller knows); returns the frame's
/// size. `encode_response` without the check, inline so that a device forms its reply in one function
/// (the AVR: no calls, the CRC folded into the copy). `Count` is the body's size type: 8 bits on a device.
template <typename Count>
__attribute__((always_inline)) inline Count form_response(char opcode, const uint8_t* body, Count size, uint8_t id,
                                                          uint8_t* out) {
  // Written out, not through a lambda or a writer object, which avr-gcc -Os would call per byte.
  Crc8Smbus crc;
  crc.update('#');
  *out++ = '#';
  const uint8_t op = static_cast<uint8_t>(opcode);
  crc.update(op);
  *out++ = op;
  for (Count left = size; left != 0; --left) {
    const uint8_t c = *body++;
    const uint8_t sent = c == ':' ? static_cast<uint8_t>('-') : c;  // ':' would end the payload
    crc.update(sent);
    *out++ = sent;
  }
  crc.update(':');
  put_byte(out, ':');
  const uint8_t id_high = hex_digit(high_nibble(id));
  crc.update(id_high);
  put_byte(out, id_high);
  const uint8_t id_low = hex_digit(static_cast<uint8_t>(id & 0xF));
  crc.update(id_low);
  put_byte(out, id_low);
  const uint8_t crc_value = crc.value();
  put_byte(out, hex_digit(high_nibble(crc_value)));
  put_byte(out, hex_digit(static_cast<uint8_t>(crc_value & 0xF)));
  put_byte(out, '\r');
  put_byte(out, '\n');
  return static_cast<Count>(size + kResponseOverhead);
}

/// Writes a log frame `#!text:xxxx\r\n`. CR and LF in `text` become spaces ('#' is kept: hosts find the
/// metadata at the end of the line, and Tether hosts resynchronise on it anyway).
Result<size_t> encode_log(ByteView text, MutableByteView out);

/// True for an opcode character: [a-zA-Z0-9?]. Inline: a device asks it twice a request (its frame's
/// opcode, the parse), and the call cost more than the test.
__attribute__((always_inline)) inline bool is_opcode(uint8_t c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '?';
}
/// True for a character the reference firmware accepts in a string argument, ':' excluded (':' would
/// end the payload on the wire): [A-Za-z0-9] and `` -_ !?%()[]{}&=+*/.,;' ``.
bool is_string_char(uint8_t c);

/// Builds and validates a request payload (`L[1]`, `M[16,"Shutdown"]`) so that bad input is rejected
/// before it reaches the wire. The first error sticks; later calls are ignored.
class RequestBuilder {
 public:
  /// Starts a payload with `opcode` (-14 invalid opcode when not [a-zA-Z0-9?]).
  explicit RequestBuilder(char opcode);
  /// Appends an integer argument (-9 after 12, -10 outside int16).
  RequestBuilder& add_int(int32_t value);
  /// Appends the string argument (-13 for a second one, -11 over 32 characters, -32 for a reserved
  /// character, -12 for any other character outside the allowed set).
  RequestBuilder& add_string(ByteView text);
  /// `Error::no_error`, or the first error.
  Error error() const { return error_; }
  /// The payload (meaningful when `error()` is no_error), e.g. `M[16,"Shutdown"]`; -22 when it would
  /// exceed kMaxHostPayload is reported by `error()`.
  ByteView payload() const { return ByteView(buffer_, size_); }

 private:
  void append(uint8_t c);
  void open_argument();

  uint8_t buffer_[kMaxHostPayload + 1];
  size_t size_ = 0;
  uint8_t arguments_ = 0;
  bool has_string_ = false;
  Error error_ = Error::no_error;
};

/// Checks a complete payload typed by a user (`L[1]`): the same rules as RequestBuilder, as the device's
/// parser would apply them, plus the host's length limit. Returns the first error or no_error.
Error validate_request_payload(ByteView payload);
/// As above, and on an error sets `error_offset` to where it was found (parse_request's offsets; a reserved
/// character's own; `payload.size()` for a payload too long or empty).
Error validate_request_payload(ByteView payload, size_t& error_offset);

}  // namespace romi
}  // namespace tether
