/// @file frame.hpp
/// The proxy protocol's frame: `COBS(crc16 ‖ payload) ‖ 0x00`, payload = one protobuf message.
///
/// - crc16 is CRC-16/MCRF4XX of the payload (core/crc.hpp), little-endian, IN FRONT of the payload (the
///   design's stack picture: CRC, then framing). Worked example: payload `0a 06 08 9f 0e 10 cf 09` has
///   crc 0x8857 and goes on the wire as `0b 57 88 0a 06 08 9f 0e 10 cf 09 00`.
/// - Senders may write a 0x00 before a frame to flush line garbage; receivers ignore empty frames.
/// - Compatibility mode (the deployed variant): no CRC; host to device `0x00 ‖ COBS(pb) ‖ 0x00`, device to
///   host `COBS(pb) ‖ 0x00`.
/// Every drop is counted by cause in LinkCounters: oversize_frames, framing_errors (bad COBS, a frame too
/// short for its CRC), crc_errors. Undecodable protobuf is the layer above's to count.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/status.hpp"
#include "tether/proxy/cobs.hpp"

namespace tether {
namespace proxy {

/// Primary mode (CRC) or the deployed variant (none).
enum class Integrity : uint8_t {
  crc16,  ///< CRC-16/MCRF4XX in front of the payload.
  none,   ///< Compatibility mode: the deployed firmware has no CRC.
};

/// Bytes a frame of `payload_size` takes on the wire at most (leading and trailing delimiters included).
constexpr size_t max_frame_size(size_t payload_size) { return cobs_max_encoded_size(payload_size + 2) + 2; }

/// Writes the frame of `payload` into `out`: an optional leading 0x00, COBS(crc ‖ payload), 0x00.
Result<size_t> encode_frame(ByteView payload, Integrity integrity, bool leading_delimiter, MutableByteView out);

/// What one byte produced.
struct FrameEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,     ///< Nothing complete.
    payload,  ///< A checked payload in `payload` (view into the decoder, valid until the next feed).
    error,    ///< A frame was dropped: `status` is frame_too_long, framing_error or crc_mismatch.
  };
  Kind kind = Kind::none;      ///< What happened.
  Status status = Status::ok;  ///< For `error`.
  ByteView payload;            ///< For `payload`.
};

/// Incremental frame decoder for payloads of at most `MaxPayload` bytes.
template <size_t MaxPayload>
class FrameDecoder {
 public:
  /// Decoder in `integrity` mode, counting into `counters` (frames_ok too); `counters` outlives it.
  FrameDecoder(Integrity integrity, LinkCounters& counters)
      : integrity_(integrity), counters_(&counters), cobs_(counters) {}

  /// Consumes one byte.
  FrameEvent feed(uint8_t byte) {
    FrameEvent event;
    const CobsEvent cobs = cobs_.feed(byte);
    if (cobs.kind == CobsEvent::Kind::error) {
      event.kind = FrameEvent::Kind::error;
      event.status = cobs.status;
      return event;
    }
    if (cobs.kind != CobsEvent::Kind::frame) return event;
    if (integrity_ == Integrity::none) {
      if (cobs.frame.empty()) return event;  // `01 00` carries nothing: an empty frame, ignored
      if (cobs.frame.size() > MaxPayload) {  // the COBS stage has room for a CRC this mode does not send
        ++counters_->oversize_frames;
        event.kind = FrameEvent::Kind::error;
        event.status = Status::frame_too_long;
        return event;
      }
      ++counters_->frames_ok;
      event.kind = FrameEvent::Kind::payload;
      event.payload = cobs.frame;
      return event;
    }
    if (cobs.frame.size() < 2) {
      ++counters_->framing_errors;
      event.kind = FrameEvent::Kind::error;
      event.status = Status::framing_error;
      return event;
    }
    const ByteView payload = cobs.frame.subview(2);
    const uint16_t sent = static_cast<uint16_t>(cobs.frame[0] | (cobs.frame[1] << 8));
    if (Crc16Mcrf4xx::compute(payload) != sent) {
      ++counters_->crc_errors;
      event.kind = FrameEvent::Kind::error;
      event.status = Status::crc_mismatch;
      return event;
    }
    ++counters_->frames_ok;
    event.kind = FrameEvent::Kind::payload;
    event.payload = payload;
    return event;
  }
  /// Forgets the frame in progress; waits for the next delimiter.
  void reset() { cobs_.reset(); }
  /// True while a frame is being received.
  bool in_frame() const { return cobs_.in_frame(); }

 private:
  Integrity integrity_;
  LinkCounters* counters_;
  CobsDecoder<MaxPayload + 2> cobs_;
};

}  // namespace proxy
}  // namespace tether
