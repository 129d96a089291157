/// @file decoder.hpp
/// Incremental reader of proxy frames (the format: encoder.hpp): COBS, with the CRC-16 of the payload
/// computed in the same byte loop in primary mode (checked at the delimiter). `feed` returns a `DecodeStatus` (core/decode_status.hpp); on `frame` read `frame()` (the checked
/// payload), on `error` read `error()`. Empty frames are ignored. Every drop is counted by cause in
/// LinkCounters: oversize_frames, framing_errors (bad COBS, a frame too short for its CRC), crc_errors;
/// frames_ok counts delivered payloads. Undecodable protobuf is the layer above's to count.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/proxy/cobs.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/errors.hpp"

namespace tether {
namespace proxy {

/// Frame decoder for payloads of at most `MaxPayload` bytes.
template <size_t MaxPayload>
class Decoder {
 public:
  /// Decoder in `integrity` mode, counting into `counters` (frames_ok too); `counters` outlives it.
  constexpr Decoder(Integrity integrity, LinkCounters& counters)
      : cobs_(counters, integrity == Integrity::crc16 ? 2 : CobsDecoder<MaxPayload + 2>::kUnchecked) {}
  /// Decoder of all zeros (a global one takes no flash for its image, .bss): `bind` it before it decodes.
  constexpr Decoder() : cobs_() {}
  /// What the first constructor takes, for a decoder made by the second.
  void bind(Integrity integrity, LinkCounters& counters) {
    cobs_.bind(counters, integrity == Integrity::crc16 ? 2 : CobsDecoder<MaxPayload + 2>::kUnchecked);
  }

  /// Consumes one byte.
  DecodeStatus feed(uint8_t byte) {
    const DecodeStatus cobs = cobs_.feed(byte);
    if (cobs == DecodeStatus::more) return DecodeStatus::more;  // the per-byte path: nothing else to do
    return cobs == DecodeStatus::error ? fail(cobs_.error()) : check(cobs_.frame());
  }
  /// Consumes `bytes` up to and including the first one that completes a frame or an error (exactly as
  /// feeding them one by one; the COBS stage runs a block's bytes in one loop, the cheap way on the AVR).
  FeedResult feed(ByteView bytes) {
    size_t used = 0;
    while (used < bytes.size()) {
      const FeedResult fed = cobs_.feed(ByteView(bytes.data() + used, bytes.size() - used));
      used += fed.consumed;
      const DecodeStatus status = fed.status == DecodeStatus::more    ? DecodeStatus::more
                                  : fed.status == DecodeStatus::error ? fail(cobs_.error())
                                                                      : check(cobs_.frame());
      if (status != DecodeStatus::more) return FeedResult{status, used};
    }
    return FeedResult{DecodeStatus::more, bytes.size()};
  }
  /// After `frame`: the checked payload (a view into the decoder, valid until the next feed).
  ByteView frame() const {
    const ByteView frame = cobs_.frame();
    // Past the CRC field (no subview call: it is on the device's path to every payload).
    if (!checked() || frame.size() < 2) return checked() ? frame.subview(2) : frame;
    return ByteView(frame.data() + 2, frame.size() - 2);
  }
  /// After `frame` in crc16 mode: the payload's CRC-16/MCRF4XX (it matched the frame's), computed while the
  /// bytes arrived: a device's duplicate filter keys on it without a second pass. 0xFFFF in `none` mode.
  uint16_t checksum() const { return cobs_.checksum(); }
  /// After `error`: why the frame was dropped (frame_too_long, framing_error or crc_mismatch).
  FrameError error() const { return error_; }
  /// Forgets the frame in progress; waits for the next delimiter.
  void reset() { cobs_.reset(); }
  /// Forgets the frame in progress; the next byte starts a new frame (no delimiter needed first).
  void restart() { cobs_.restart(); }
  /// True while a frame is being received.
  bool in_frame() const { return cobs_.in_frame(); }

 private:
  // A complete COBS frame: the payload after its CRC check (primary) or as is (compatibility mode).
  DecodeStatus check(ByteView frame) {
    if (!checked()) {
      if (frame.empty()) return DecodeStatus::more;  // `01 00` carries nothing: an empty frame, ignored
      if (frame.size() > MaxPayload) {  // the COBS stage has room for a CRC this mode does not send
        ++cobs_.counters().oversize_frames;
        return fail(FrameError::frame_too_long);
      }
      ++cobs_.counters().frames_ok;
      return DecodeStatus::frame;
    }
    if (frame.size() < 2) {
      ++cobs_.counters().framing_errors;
      return fail(FrameError::framing_error);
    }
    const uint16_t sent = static_cast<uint16_t>(frame[0] | (frame[1] << 8));
    if (cobs_.checksum() != sent) {  // computed while the bytes arrived: no second pass
      ++cobs_.counters().crc_errors;
      return fail(FrameError::crc_mismatch);
    }
    ++cobs_.counters().frames_ok;
    return DecodeStatus::frame;
  }
  DecodeStatus fail(FrameError error) {
    error_ = error;
    return DecodeStatus::error;
  }

  // The mode is the COBS stage's: a checksum from offset 2 (the CRC field) on, or none (no member for it:
  // the device's static RAM).
  bool checked() const { return cobs_.checked(); }

  CobsDecoder<MaxPayload + 2> cobs_;
  FrameError error_ = FrameError::none;
};

}  // namespace proxy
}  // namespace tether
