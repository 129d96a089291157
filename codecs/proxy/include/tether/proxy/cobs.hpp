/// @file cobs.hpp
/// Consistent Overhead Byte Stuffing: frames of arbitrary bytes separated by 0x00 on a byte stream.
///
/// Standard COBS (Cheshire & Baker): the encoded frame has no 0x00 byte; each code byte `c` (1..255) says
/// that `c - 1` data bytes follow, then a zero, except after a code of 255 (254 data bytes, no zero) and
/// at the end of the frame. Overhead: one byte, plus one per 254 data bytes. The 0x00 delimiter itself is
/// written by the frame layer (frame.hpp).
///
/// `CobsDecoder` is incremental (one byte per call, no allocation): it returns a frame at each 0x00,
/// ignores empty frames (so senders may put a 0x00 before a frame to flush line garbage), bounds the
/// decoded size, and after any error skips to the next 0x00 (resynchronisation).
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/status.hpp"

namespace tether {
namespace proxy {

/// Largest COBS encoding of `size` bytes (no delimiter).
constexpr size_t cobs_max_encoded_size(size_t size) { return size + size / 254 + 1; }

/// COBS-encodes `input` into `out` (no delimiter); the encoded length or `Status::buffer_too_small`.
Result<size_t> cobs_encode(ByteView input, MutableByteView out);

/// COBS-decodes one complete encoded frame (no delimiter) into `out`. `Status::framing_error` for
/// invalid COBS (a 0x00 inside, or a code running past the end), `Status::buffer_too_small`.
Result<size_t> cobs_decode(ByteView input, MutableByteView out);

/// What one byte produced.
struct CobsEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,   ///< Nothing complete.
    frame,  ///< A decoded frame in `frame` (a view into the decoder, valid until the next feed).
    error,  ///< A frame was dropped: `status` is frame_too_long or framing_error.
  };
  Kind kind = Kind::none;        ///< What happened.
  Status status = Status::ok;    ///< For `error`.
  ByteView frame;                ///< For `frame`.
};

/// Incremental COBS decoder for frames of at most `Capacity` decoded bytes.
template <size_t Capacity>
class CobsDecoder {
 public:
  /// Decoder counting into `counters` (oversize_frames, framing_errors, resyncs); outlives it.
  explicit CobsDecoder(LinkCounters& counters) : counters_(&counters) {}

  /// Consumes one byte.
  CobsEvent feed(uint8_t byte) {
    CobsEvent event;
    if (byte == 0x00) {
      if (skipping_) {
        skipping_ = false;  // resynchronised on the delimiter
        ++counters_->resyncs;
      } else if (left_ != 0) {
        event = fail(Status::framing_error);  // the frame ended inside a block
        skipping_ = false;
      } else if (started_) {
        event.kind = CobsEvent::Kind::frame;
        event.frame = ByteView(buffer_, size_);
      }
      started_ = false;
      size_ = 0;
      left_ = 0;
      return event;
    }
    if (skipping_) return event;
    if (left_ == 0) {  // a code byte
      if (started_ && last_code_ != 0xFF && !append(0x00)) return fail(Status::frame_too_long);
      started_ = true;
      last_code_ = byte;
      left_ = static_cast<uint8_t>(byte - 1);
      return event;
    }
    --left_;
    if (!append(byte)) return fail(Status::frame_too_long);
    return event;
  }
  /// Forgets the frame in progress and waits for the next 0x00.
  void reset() {
    skipping_ = true;
    size_ = 0;
    left_ = 0;
    started_ = false;
  }
  /// True while a frame is being received (a partial-frame deadline watches it).
  bool in_frame() const { return started_ && !skipping_; }

 private:
  bool append(uint8_t byte) {
    if (size_ == Capacity) return false;
    buffer_[size_++] = byte;
    return true;
  }
  CobsEvent fail(Status status) {
    CobsEvent event;
    event.kind = CobsEvent::Kind::error;
    event.status = status;
    if (status == Status::frame_too_long) {
      ++counters_->oversize_frames;
    } else {
      ++counters_->framing_errors;
    }
    skipping_ = status == Status::frame_too_long;  // bad COBS already ended at the delimiter
    size_ = 0;
    left_ = 0;
    started_ = false;
    return event;
  }

  LinkCounters* counters_;
  uint8_t buffer_[Capacity];
  size_t size_ = 0;
  uint8_t left_ = 0;        // data bytes left in the current block
  uint8_t last_code_ = 0;   // code of the current block
  bool started_ = false;    // a code byte was seen since the last delimiter
  bool skipping_ = false;   // after an error: ignore bytes until the next 0x00
};

}  // namespace proxy
}  // namespace tether
