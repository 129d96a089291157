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
///   3. After an error the decoder skips to the next header (or the end of the line). A header arriving
///      inside a message (the sender reset mid-message) ends that message with an error and starts the
///      next one: it is never swallowed.
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

namespace tether {
namespace elcano {

/// Decoder for one generation, keeping at most `Capacity` bytes of a message.
template <size_t Capacity = 96>
class Decoder {
 public:
  /// Decoder of `generation` counting into `counters` (frames_ok, crc_errors, framing_errors,
  /// oversize_frames, resyncs); `counters` outlives it.
  Decoder(Generation generation, LinkCounters& counters) : generation_(generation), counters_(&counters) {}

  /// Consumes one byte.
  DecodeStatus feed(uint8_t byte);
  /// Consumes `bytes` up to and including the first one that completes a message or an error.
  FeedResult feed(ByteView bytes) { return feed_until_event(*this, bytes); }
  /// After `frame`: the message.
  const Message& frame() const { return message_; }
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

  DecodeStatus step(uint8_t byte);
  DecodeStatus fail(Error error);
  DecodeStatus finish();
  bool keep(uint8_t byte);
  bool store_value();
  int32_t signed_value() const;

  Generation generation_;
  LinkCounters* counters_;
  State state_ = State::header;
  Error error_ = Error::success;
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

#include "tether/elcano/decoder_impl.hpp"
