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
#include "tether/core/crc.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/core/status.hpp"
#include "tether/proxy/errors.hpp"

namespace tether {
namespace proxy {

/// Largest COBS encoding of `size` bytes (no delimiter). Divides only from 254 bytes on: on the AVR a
/// 16-bit division is a ~200-cycle library call, and the frames it sizes are shorter.
constexpr size_t cobs_max_encoded_size(size_t size) { return size + (size < 254 ? 0 : size / 254) + 1; }

namespace detail {
/// COBS encoding one byte at a time into a buffer with room for the worst case: the one encoding loop,
/// shared by `cobs_encode` and the frame writer (encoder.cpp), which folds its CRC into the same pass.
class CobsWriter {
 public:
  /// Writer whose encoding starts at `out`.
  explicit CobsWriter(uint8_t* out) : start_(out), code_at_(out), write_(out + 1) {}
  /// Appends `byte` (always inline: the per-byte step of the callers' loops).
  __attribute__((always_inline)) void put(uint8_t byte) {
    if (byte == 0x00) {
      close_block();
      return;
    }
    *write_++ = byte;
    if (++code_ == 0xFF) close_block();  // a full block of 254 data bytes: no zero follows it
  }
  /// Leaves room for `count` bytes at the very start (before any `put`), counted as non-zero data in
  /// the first block: the frame writer's CRC, known only after the payload.
  void reserve(uint8_t count) {
    write_ += count;
    code_ = static_cast<uint8_t>(code_ + count);
  }
  /// Closes the last block; returns the encoded size.
  size_t finish() {
    *code_at_ = code_;
    return static_cast<size_t>(write_ - start_);
  }

 private:
  __attribute__((always_inline)) void close_block() {
    *code_at_ = code_;
    code_at_ = write_++;
    code_ = 1;
  }

  uint8_t* start_;
  uint8_t* code_at_;  // where the current block's code byte goes
  uint8_t* write_;
  uint8_t code_ = 1;
};
}  // namespace detail

/// COBS-encodes `input` into `out` (no delimiter); the encoded length or `Status::buffer_too_small`.
Result<size_t> cobs_encode(ByteView input, MutableByteView out);

/// COBS-decodes one complete encoded frame (no delimiter) into `out`. `Status::framing_error` for
/// invalid COBS (a 0x00 inside, or a code running past the end), `Status::buffer_too_small`.
Result<size_t> cobs_decode(ByteView input, MutableByteView out);

namespace detail {
/// Index type of a buffer of `Capacity` bytes: one byte when it fits (the AVR then does 8-bit arithmetic
/// per byte instead of 16-bit), `size_t` otherwise. Its largest value is never a valid index.
template <bool kSmall>
struct CobsIndex {
  using type = uint8_t;
};
template <>
struct CobsIndex<false> {
  using type = size_t;
};
}  // namespace detail

/// Incremental COBS decoder for frames of at most `Capacity` decoded bytes: `feed` returns a
/// `DecodeStatus`; on `frame` read `frame()`, on `error` read `error()` (frame_too_long or framing_error).
/// Optionally it also computes the CRC-16/MCRF4XX of the decoded bytes from an offset on, in the same
/// byte loop (`checksum()`): the proxy frame's check without a second pass over the frame.
template <size_t Capacity>
class CobsDecoder {
  using Index = typename detail::CobsIndex<(Capacity < 255)>::type;

 public:
  /// Offset that disables the checksum (the default).
  static constexpr size_t kUnchecked = static_cast<size_t>(static_cast<Index>(-1));

  /// Decoder counting into `counters` (oversize_frames, framing_errors, resyncs); outlives it. With
  /// `checked_from` < `Capacity`, `checksum()` covers each frame's decoded bytes from that offset on.
  explicit CobsDecoder(LinkCounters& counters, size_t checked_from = kUnchecked)
      : counters_(&counters), checked_from_(static_cast<Index>(checked_from < Capacity ? checked_from : kUnchecked)) {}

  /// Consumes one byte.
  __attribute__((always_inline)) DecodeStatus feed(uint8_t byte) {
    if (left_ != 0 && byte != 0x00 && size_ != Capacity) {  // a data byte that fits: the per-byte path
      --left_;
      store(byte);
      return DecodeStatus::more;
    }
    return feed_rare(byte);
  }
  /// Consumes `bytes` up to and including the first one that completes a frame or an error; the same
  /// events and state as feeding them one by one, but a block's data bytes go through one tight loop
  /// (on the AVR the decoder's state stays in registers instead of a load and store per byte).
  FeedResult feed(ByteView bytes) {
    const uint8_t* const data = bytes.data();
    const size_t size = bytes.size();
    size_t used = 0;
    while (used < size) {
      if (left_ != 0) used += take_data(data + used, size - used);
      if (used == size) break;
      // Not a data byte that fits (take_data took those): feed(uint8_t)'s other path.
      const DecodeStatus status = feed_rare(data[used++]);
      if (status != DecodeStatus::more) return FeedResult{status, used};
    }
    return FeedResult{DecodeStatus::more, size};
  }
  /// After `frame`: the decoded frame (a view into the decoder, valid until the next feed).
  ByteView frame() const { return ByteView(buffer_, size_); }
  /// After `frame`: CRC-16/MCRF4XX of `frame()` from the constructor's `checked_from` on (its initial
  /// value when the frame is not longer than that offset).
  uint16_t checksum() const { return crc_.value(); }
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
  // Everything but a data byte that fits: a code byte, the delimiter, a byte while skipping, overflow.
  // Out of line so that the caller's byte loop stays small (on the AVR: its registers are not spilled).
  __attribute__((noinline)) DecodeStatus feed_rare(uint8_t byte) {
    if (left_ != 0 && byte != 0x00) return fail(FrameError::frame_too_long);  // the data byte did not fit
    if (byte == 0x00) return end_frame();
    if (skipping_) return DecodeStatus::more;
    // A code byte (left_ is 0 here).
    if (started_ && last_code_ != 0xFF) {  // the zero that ended the previous block
      if (size_ == Capacity) return fail(FrameError::frame_too_long);
      store(0x00);
    }
    if (!started_) {  // the previous frame stays readable until the next one starts
      size_ = 0;
      crc_.reset();
    }
    started_ = true;
    last_code_ = byte;
    left_ = static_cast<uint8_t>(byte - 1);
    return DecodeStatus::more;
  }
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
  // The run of data bytes at `bytes` that the current block still holds, up to a zero (bad COBS, left to
  // `feed`) or a full buffer; returns how many it kept. feed(uint8_t)'s per-byte path, with the state
  // in locals; out of line so that it gets the registers to itself whatever the caller is.
  __attribute__((noinline)) size_t take_data(const uint8_t* bytes, size_t size) {
    size_t limit = left_;
    if (size < limit) limit = size;
    if (Capacity - size_ < limit) limit = Capacity - size_;
    const uint8_t* in = bytes;
    const uint8_t* const end = bytes + limit;
    uint8_t* out = buffer_ + size_;
    // Bytes before the checked offset are only copied; the rest also go through the CRC.
    uint8_t* const checked = buffer_ + (checked_from_ < Capacity ? checked_from_ : Capacity);
    while (in != end && out < checked && *in != 0x00) *out++ = *in++;
    Crc16Mcrf4xx crc = crc_;
    while (in != end && *in != 0x00) {
      const uint8_t byte = *in++;
      crc.update(byte);
      *out++ = byte;
    }
    crc_ = crc;
    const size_t used = static_cast<size_t>(in - bytes);
    left_ = static_cast<uint8_t>(left_ - used);
    size_ = static_cast<Index>(size_ + used);
    return used;
  }
  // Keeps a decoded byte (room checked by the caller). Always inline: the per-byte path, which -Os would
  // otherwise make a call.
  __attribute__((always_inline)) void store(uint8_t byte) {
    if (size_ >= checked_from_) crc_.update(byte);
    buffer_[size_++] = byte;
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
  Index size_ = 0;
  Index checked_from_;      // first decoded byte the checksum covers (kUnchecked: none)
  uint8_t left_ = 0;        // data bytes left in the current block (0 while skipping)
  uint8_t last_code_ = 0;   // code of the current block
  bool started_ = false;    // a code byte was seen since the last delimiter
  bool skipping_ = false;   // after an error: ignore bytes until the next 0x00
  FrameError error_ = FrameError::none;
  Crc16Mcrf4xx crc_;
};

}  // namespace proxy
}  // namespace tether
