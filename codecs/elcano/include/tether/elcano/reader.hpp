/// @file reader.hpp
/// Incremental, non-blocking Elcano message reader: feed it whatever bytes arrived, one call per byte; it
/// resumes where it stopped and returns at most one event per byte. No allocation; `Capacity` bounds
/// the bytes kept per message.
///
/// Rules (the reference's, made precise):
///   1. Spaces, tabs, `\r` and NUL are ignored anywhere, also inside numbers.
///   2. A message starts at a header D, S, G or X; anything else where a header is expected is bad_type.
///   3. After an error the reader skips to the next header (or the end of the line). A header arriving
///      inside a message (the sender reset mid-message) ends that message with an error and starts the
///      next one: it is never swallowed.
///   4. Numbers: optional `-`, at least one decimal digit, int32; one that does not fit is bad_number (never
///      wrapped). 2147483647 is the "unset" marker: the field stays unset (inval_comb if required).
///   Where this differs from the reference reader, and why: docs/elcano.md, "Compatibility with the
///   reference reader".
///   5. Generation B `p` carries `E,N`; generation D carries `p` and `q` and a decimal CRC-8 trailer
///      (bad_crc when it does not match).
///   6. At `\n` the required fields of the type are checked (inval_comb).
/// A successful event also carries the message's bytes without whitespace (`forward`), header to the last
/// `}` plus the generation D trailer and `\n`: what a ring node forwards, byte-identical to the input when
/// the input had no whitespace (generation D always), whitespace-stripped otherwise, as the reference does.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/elcano/message.hpp"

namespace tether {
namespace elcano {

/// What one byte produced.
struct ReadEvent {
  /// Event kinds.
  enum class Kind : uint8_t { none, message, error };
  Kind kind = Kind::none;                  ///< What happened.
  ReadError error = ReadError::success;    ///< For `error`.
  Message message;                         ///< For `message`.
  ByteView forward;                        ///< For `message`: its bytes to forward (valid until next feed).
};

/// Reader for one generation, keeping at most `Capacity` bytes of a message.
template <size_t Capacity = 96>
class Reader {
 public:
  /// Reader of `generation` counting into `counters` (frames_ok, crc_errors, framing_errors,
  /// oversize_frames, resyncs); `counters` outlives it.
  Reader(Generation generation, LinkCounters& counters) : generation_(generation), counters_(&counters) {}

  /// Consumes one byte; the whole event by value (convenient; copies the message).
  ReadEvent feed(uint8_t byte);
  /// Consumes one byte; the fast path (no copy per byte, what the AVR ring node uses): on `message` read
  /// `message()` and `forward()`, on `error` read `error()`, before the next byte.
  ReadEvent::Kind consume(uint8_t byte);
  /// The message completed by the last `consume` that returned `message`.
  const Message& message() const { return message_; }
  /// Its bytes to forward (see the file overview); valid until the next byte.
  ByteView forward() const { return ByteView(buffer_, size_); }
  /// The error of the last `consume` that returned `error`.
  ReadError error() const { return error_; }
  /// Drops the message in progress (e.g. its deadline passed); skips to the next header.
  void reset() {
    state_ = State::skip;
    size_ = 0;
  }
  /// True while a message is in progress (what a partial-message deadline watches).
  bool in_message() const { return state_ != State::header && state_ != State::skip; }

 private:
  enum class State : uint8_t { header, lcurly, letter, number, trailer, skip };

  ReadEvent::Kind step(uint8_t byte);
  ReadEvent::Kind fail(ReadError error);
  ReadEvent::Kind finish();
  bool keep(uint8_t byte);
  bool store_value();
  int32_t signed_value() const;

  Generation generation_;
  LinkCounters* counters_;
  State state_ = State::header;
  ReadError error_ = ReadError::success;
  Message message_;
  uint8_t buffer_[Capacity];
  size_t size_ = 0;
  size_t crc_end_ = 0;     // bytes covered by the generation D CRC
  char letter_ = 0;
  bool second_ = false;    // generation B `p`: reading N after the comma
  bool negative_ = false;
  bool digits_ = false;
  uint32_t value_ = 0;     // magnitude, at most 2^31 (32-bit: the AVR has no cheap 64-bit multiply)
  int32_t first_ = 0;      // generation B `p`: E while N is read
  uint16_t trailer_ = 0;
  bool trailer_digits_ = false;
};

}  // namespace elcano
}  // namespace tether

#include "tether/elcano/reader_impl.hpp"
