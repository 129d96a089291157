/// @file cobs.hpp
/// Consistent Overhead Byte Stuffing: frames of arbitrary bytes separated by 0x00 on a byte stream.
///
/// Standard COBS (Cheshire & Baker): the encoded frame has no 0x00 byte; each code byte `c` (1..255) says
/// that `c - 1` data bytes follow, then a zero, except after a code of 255 (254 data bytes, no zero) and
/// at the end of the frame. Overhead: one byte, plus one per 254 data bytes. The 0x00 delimiter itself is
/// written by the frame layer (frame.hpp).
///
/// `CobsDecoder` is incremental (one byte per call, no allocation): it completes a frame at each 0x00,
/// ignores empty frames (so senders may put a 0x00 before a frame to flush line garbage), bounds the
/// decoded size, and after any error skips to the next 0x00 (resynchronisation).
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/core/status.hpp"
#include "tether/proxy/errors.hpp"

namespace tether {
namespace proxy {

/// Largest COBS encoding of `size` bytes (no delimiter).
constexpr size_t cobs_max_encoded_size(size_t size) { return size + size / 254 + 1; }

/// COBS-encodes `input` into `out` (no delimiter); the encoded length or `Status::buffer_too_small`.
Result<size_t> cobs_encode(ByteView input, MutableByteView out);

/// COBS-decodes one complete encoded frame (no delimiter) into `out`. `Status::framing_error` for
/// invalid COBS (a 0x00 inside, or a code running past the end), `Status::buffer_too_small`.
Result<size_t> cobs_decode(ByteView input, MutableByteView out);

/// Incremental COBS decoder for frames of at most `Capacity` decoded bytes: `feed` returns a
/// `DecodeStatus`; on `frame` read `frame()`, on `error` read `error()` (frame_too_long or framing_error).
template <size_t Capacity>
class CobsDecoder {
 public:
  /// Decoder counting into `counters` (oversize_frames, framing_errors, resyncs); outlives it.
  explicit CobsDecoder(LinkCounters& counters) : counters_(&counters) {}

  /// Consumes one byte.
  DecodeStatus feed(uint8_t byte) {
    if (byte == 0x00) return end_frame();
    if (skipping_) return DecodeStatus::more;
    if (left_ == 0) {  // a code byte
      if (started_ && last_code_ != 0xFF && !append(0x00)) return fail(FrameError::frame_too_long);
      if (!started_) size_ = 0;  // the previous frame stays readable until the next one starts
      started_ = true;
      last_code_ = byte;
      left_ = static_cast<uint8_t>(byte - 1);
      return DecodeStatus::more;
    }
    --left_;
    if (!append(byte)) return fail(FrameError::frame_too_long);
    return DecodeStatus::more;
  }
  /// Consumes `bytes` up to and including the first one that completes a frame or an error.
  FeedResult feed(ByteView bytes) { return feed_until_event(*this, bytes); }
  /// After `frame`: the decoded frame (a view into the decoder, valid until the next feed).
  ByteView frame() const { return ByteView(buffer_, size_); }
  /// After `error`: why the frame was dropped.
  FrameError error() const { return error_; }
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
  // The delimiter: completes the frame in progress, reports a block cut short, or ends a resync.
  DecodeStatus end_frame() {
    DecodeStatus status = DecodeStatus::more;
    if (skipping_) {
      skipping_ = false;  // resynchronised on the delimiter
      ++counters_->resyncs;
    } else if (left_ != 0) {
      status = fail(FrameError::framing_error);  // the frame ended inside a block
      skipping_ = false;
    } else if (started_) {
      status = DecodeStatus::frame;  // `size_` bytes stay in `buffer_` until the next code byte
    } else {
      size_ = 0;
    }
    started_ = false;
    left_ = 0;
    return status;
  }
  bool append(uint8_t byte) {
    if (size_ == Capacity) return false;
    buffer_[size_++] = byte;
    return true;
  }
  DecodeStatus fail(FrameError error) {
    error_ = error;
    if (error == FrameError::frame_too_long) {
      ++counters_->oversize_frames;
    } else {
      ++counters_->framing_errors;
    }
    skipping_ = error == FrameError::frame_too_long;  // bad COBS already ended at the delimiter
    size_ = 0;
    left_ = 0;
    started_ = false;
    return DecodeStatus::error;
  }

  LinkCounters* counters_;
  uint8_t buffer_[Capacity];
  size_t size_ = 0;
  uint8_t left_ = 0;        // data bytes left in the current block
  uint8_t last_code_ = 0;   // code of the current block
  bool started_ = false;    // a code byte was seen since the last delimiter
  bool skipping_ = false;   // after an error: ignore bytes until the next 0x00
  FrameError error_ = FrameError::none;
};

}  // namespace proxy
}  // namespace tether
