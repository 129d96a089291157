/// @file decoder.hpp
/// Incremental, non-blocking Elcano message decoder: feed it whatever bytes arrived (`feed(byte)`, or
/// `feed(bytes)` which stops at the first message or error); it resumes where it stopped. Each byte
/// returns a `DecodeStatus` (core/decode_status.hpp); on `frame` read `frame()` (the message) and
/// `forward()`, on `error` read `error()`, before the next byte. No allocation; `Capacity` bounds the
/// bytes kept per message.
///
/// Rules (the reference's, made precise):
///   1. Spaces, tabs, `\r` and NUL are ignored anywhere, also inside numbers.
///   2. A message starts at a header D, S, G or X; anything else where a header is expected is bad_type.
///   3. After an error the decoder skips to the next header (or the end of the line) and counts a resync
///      there; an error found at the line end itself (inval_comb, a bad CRC, a `\n` inside an attribute)
///      leaves nothing to skip and counts none. A header arriving inside a message (the sender reset
///      mid-message) ends that message with an error and starts the next one: it is never swallowed.
///   4. Numbers: optional `-`, at least one decimal digit, int32; one that does not fit is bad_number (never
///      wrapped). 2147483647 is the "unset" marker: the field stays unset (inval_comb if required).
///   Where this differs from the reference reader, and why: docs/elcano.md, "Compatibility with the
///   reference reader".
///   5. Generation B `p` carries `E,N`; generation D carries `p` and `q` and a decimal CRC-8 trailer
///      (bad_crc when it does not match).
///   6. At `\n` the required fields of the type are checked (inval_comb).
/// A decoded message also comes with its bytes without whitespace (`forward`), header to the last
/// `}` plus the generation D trailer and `\n`: what a ring node forwards, byte-identical to the input when
/// the input had no whitespace (generation D always), whitespace-stripped otherwise, as the reference does.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/elcano/errors.hpp"
#include "tether/elcano/message.hpp"

#if defined(__AVR__)
#include <avr/pgmspace.h>
#endif

namespace tether {
namespace elcano {
namespace detail {

/// kFieldOffsets: marks the letters that name a field in generation D only (`p` E alone, `o`, `q`).
constexpr uint8_t kGenerationDOnly = 0x80;
/// The attribute letters' fields, by `letter - 'a'`: offsetof(Message, field), kGenerationDOnly added for
/// the generation D letters; 0 for letters that name no field (src/message.cpp; in flash on the AVR).
#if defined(__AVR__)
extern const uint8_t kFieldOffsets[26] PROGMEM;
#else
extern const uint8_t kFieldOffsets[26];
#endif

}  // namespace detail

/// Decoder for one generation, keeping at most `Capacity` bytes of a message.
template <size_t Capacity = 96>
class Decoder {
 public:
  /// Decoder of `generation` counting into `counters` (frames_ok, crc_errors, framing_errors,
  /// oversize_frames, resyncs); `counters` outlives it.
  Decoder(Generation generation, LinkCounters& counters) : generation_(generation), counters_(&counters) {}

  /// Consumes one byte. The bytes inside attributes (`{`, a letter, digits, `}`, spaces) take a short
  /// inline path; headers, line ends and everything unusual go through the state machine (the
  /// per-byte cost on the AVR). Both give the same results.
  DecodeStatus feed(uint8_t byte) {
    if (size_ != Capacity) {
      if (state_ == State::number) {
        const uint8_t digit = static_cast<uint8_t>(byte - '0');
        if (digit < 10 && digits_ < kSafeDigits) {
          // Fewer than 9 digits so far: one more cannot leave int32, no range check needed; up to 4
          // digits in 16-bit arithmetic (the AVR multiplies that inline, 32-bit is a library call).
          if (digits_ < 4) {
            value_ = static_cast<uint16_t>(static_cast<uint16_t>(value_) * 10u + digit);
          } else {
            value_ = value_ * 10u + digit;
          }
          ++digits_;
          buffer_[size_++] = byte;
          return DecodeStatus::more;
        }
        if (byte == '-' && digits_ == 0 && !negative_) {
          negative_ = true;
          buffer_[size_++] = byte;
          return DecodeStatus::more;
        }
        if (byte == '}' && digits_ != 0 && field_ != 0) {
          *field(field_) = signed_value();
          buffer_[size_++] = byte;
          state_ = State::lcurly;
          return DecodeStatus::more;
        }
      } else if (state_ == State::lcurly) {
        if (byte == '{') {
          buffer_[size_++] = byte;
          state_ = State::letter;
          return DecodeStatus::more;
        }
        if (byte == '\n') return finish();
      } else if (state_ == State::header) {
        if (byte == 'D' || byte == 'S' || byte == 'G' || byte == 'X') {
          start(byte);
          return DecodeStatus::more;
        }
      } else if (state_ == State::letter) {
        const uint8_t field = field_of(byte);
        if (field != 0) {
          buffer_[size_++] = byte;
          begin_number(field);
          return DecodeStatus::more;
        }
      }
    }
    if (byte == ' ') return DecodeStatus::more;  // ignored anywhere (rule 1)
    return feed_slow(byte);
  }
  /// Consumes `bytes` up to and including the first one that completes a message or an error, with
  /// exactly the results of feeding them one at a time. The bytes inside a message (attributes, the
  /// generation D trailer) are taken in one loop with the write position, the state and the digit count
  /// in registers (on the AVR the call per byte and the members' loads and stores cost more
  /// than the parsing itself). Prefer it wherever bytes arrive in runs.
  FeedResult feed(ByteView bytes);
  /// After `frame`: the message.
  const Message& frame() const { return message_; }
  /// After `frame`: the `field_bits` of the fields the message may have set (every field outside them is
  /// `kUnset`): `speed | angle` for a drive that carried only those (the usual message on a ring), else
  /// `field_bits::all`. A copy of the message can then skip the rest.
  uint8_t fields() const { return fields_; }
  /// After `frame`: the message's bytes to forward (see the file overview); valid until the next byte.
  ByteView forward() const { return ByteView(buffer_, size_); }
  /// After `error`: why the message was dropped.
  Error error() const { return error_; }
  /// Drops the message in progress (e.g. its deadline passed); skips to the next header.
  void reset() {
    state_ = State::skip;
    size_ = 0;
  }
  /// True while a message is in progress (what a partial-message deadline watches).
  bool in_frame() const { return state_ != State::header && state_ != State::skip; }

 private:
  enum class State : uint8_t { header, lcurly, letter, number, trailer, skip };
  // Each attribute of a complete message keeps at least 4 bytes (`{s1}`): attributes_ cannot wrap.
  static_assert(Capacity <= 4 * 255, "Decoder counts a message's attributes in 8 bits");
  // Digits any int32 magnitude can take without a range check (999999999 < 2^31).
  static constexpr uint8_t kSafeDigits = 9;

  DecodeStatus feed_slow(uint8_t byte);
  // Where feed(bytes)'s run stopped: the first byte it did not take, or just after a message it completed.
  struct RunEnd {
    const uint8_t* next;
    bool frame;
  };
  // feed(bytes)'s loop over the bytes of a message (see there).
  RunEnd run(const uint8_t* next, const uint8_t* end);
  // feed(bytes) from `next`, a byte its run did not take, to the next event or the end of `bytes`.
  FeedResult feed_after_run(ByteView bytes, const uint8_t* next);
  // feed(bytes) on the bytes run() leaves: feed(byte) out of line (the run keeps its registers).
  DecodeStatus feed_outside_run(uint8_t byte);
  // Where in `message_` the field attribute `letter` sets in this generation is (its offset, never 0:
  // `type` is there); 0 for unknown letters and for generation B `p`, which sets two fields
  // (store_value). An offset, not a member pointer: a null one is all ones, which would move every
  // decoder from .bss to .data (flash and a boot copy on the AVR). A table lookup, inline: a switch was
  // a jump table behind a call, and the call made feed(bytes)'s loop keep its values on the stack.
  __attribute__((always_inline)) uint8_t field_of(uint8_t letter) const {
    const uint8_t index = static_cast<uint8_t>(letter - 'a');
    if (index >= sizeof detail::kFieldOffsets) return 0;
#if defined(__AVR__)
    const uint8_t entry = pgm_read_byte(&detail::kFieldOffsets[index]);
#else
    const uint8_t entry = detail::kFieldOffsets[index];
#endif
    if ((entry & detail::kGenerationDOnly) == 0) return entry;
    return generation_ == Generation::d ? static_cast<uint8_t>(entry & ~detail::kGenerationDOnly) : 0;
  }
  // The int32 field of `message_` at `offset` (from field_of).
  int32_t* field(uint8_t offset) {
    return reinterpret_cast<int32_t*>(reinterpret_cast<uint8_t*>(&message_) + offset);
  }
  // After an attribute's letter (already kept): its number starts, for `field` (field_of the letter).
  void begin_number(uint8_t field) {
    ++attributes_;
    field_ = field;
    second_ = false;
    negative_ = false;
    digits_ = 0;
    value_ = 0;
    state_ = State::number;
  }
  DecodeStatus step(uint8_t byte);
  // A message starts at `header` (kept), from step(); open() is the part run() inlines (state aside).
  void start(uint8_t header);
  void open(uint8_t header);
  // The number read so far, `negative` or not (`small` while it has at most 4 digits, then value_).
  int32_t value_of(uint8_t digits, uint16_t small, bool negative) const;
  DecodeStatus fail(Error error);
  // fail() for an error found at the `\n` that ends the message: the next byte starts a line.
  DecodeStatus fail_at_line_end(Error error);
  DecodeStatus finish();
  bool keep(uint8_t byte);
  bool store_value();
  int32_t signed_value() const;

  // The per-byte state first and the buffer last: on the AVR a member more than 63 bytes into the
  // object costs an address computation on every access.
  State state_ = State::header;
  Generation generation_;
  uint8_t digits_ = 0;     // digits of the number so far (saturates at 255)
  uint8_t field_ = 0;      // what `}` sets: field_of(letter); 0 only for generation B `p` (E,N)
  uint8_t attributes_ = 0;  // attribute letters taken since open() (a complete message's: <= Capacity / 4)
  // The fields of message_ that may hold a value (field_bits): none before the first message, a complete
  // message's fields_set(), all while a message is read or after one failed; open() resets only those.
  uint8_t fields_ = 0;
  size_t size_ = 0;
  uint32_t value_ = 0;     // magnitude, at most 2^31 (32-bit: the AVR has no cheap 64-bit multiply)
  bool second_ = false;    // generation B `p`: reading N after the comma
  bool negative_ = false;
  bool trailer_digits_ = false;
  Error error_ = Error::success;
  uint16_t trailer_ = 0;
  int32_t first_ = 0;      // generation B `p`: E while N is read
  size_t crc_end_ = 0;     // bytes covered by the generation D CRC
  LinkCounters* counters_;
  Message message_;
  uint8_t buffer_[Capacity];
};

}  // namespace elcano
}  // namespace tether

#include "tether/elcano/decoder_impl.hpp"
