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

namespace detail {
#if defined(__AVR__)
/// The decoder's CRC-16/MCRF4XX on the AVR: the bare register (Crc16Mcrf4xx keeps it private), which
/// the decoder's run loop holds in CPU registers through its assembly. Steps as Crc16Mcrf4xx's AVR back end.
struct CobsCrc {
  /// A register ready for a new computation.
  constexpr CobsCrc() : state(0xFFFF) {}
  /// A register holding `initial` (constructors, not member initialisers: the Arduino IDE compiles C++11,
  /// where a struct with those is no aggregate).
  explicit constexpr CobsCrc(uint16_t initial) : state(initial) {}
  uint16_t state;  ///< The register; it is also the checksum (no final xor).
  /// A register of all zeros (an unbound decoder's: reset before a frame's first byte).
  static constexpr CobsCrc zero() { return CobsCrc(0); }
  /// Starts a new computation.
  void reset() { state = 0xFFFF; }
  /// Feeds one byte (avr-libc's step, inline).
  __attribute__((always_inline)) void update(uint8_t byte) { state = _crc_ccitt_update(state, byte); }
  /// Checksum of the bytes fed since the last reset.
  uint16_t value() const { return state; }
};
#else
/// The decoder's CRC-16/MCRF4XX on the host: the core's.
using CobsCrc = Crc16Mcrf4xx;
#endif
/// An unbound decoder's register (all zeros on the AVR: a global decoder is in .bss).
#if defined(__AVR__)
constexpr CobsCrc unbound_crc() { return CobsCrc::zero(); }
#else
inline CobsCrc unbound_crc() { return CobsCrc(); }
#endif
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

 private:
  static constexpr Index kUncheckedIndex = static_cast<Index>(-1);

 public:

  /// Decoder counting into `counters` (oversize_frames, framing_errors, resyncs); outlives it. With
  /// `checked_from` < `Capacity`, `checksum()` covers each frame's decoded bytes from that offset on.
  constexpr explicit CobsDecoder(LinkCounters& counters, size_t checked_from = kUnchecked)
      : counters_(&counters), checked_from_(static_cast<Index>(checked_from < Capacity ? checked_from : kUnchecked)), buffer_{} {}
  /// Decoder of all zeros (a global one takes no flash for its image, .bss): `bind` it before it decodes.
  constexpr CobsDecoder() : counters_(nullptr), checked_from_(0), crc_(detail::unbound_crc()), buffer_{} {}
  /// What the first constructor takes, for a decoder made by the second.
  void bind(LinkCounters& counters, size_t checked_from = kUnchecked) {
    counters_ = &counters;
    checked_from_ = static_cast<Index>(checked_from < Capacity ? checked_from : kUnchecked);
  }

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
    const uint8_t* in = bytes.data();
    size_t rest = bytes.size();
    while (rest != 0) {
      if (!skipping_) {
        // At most 255 bytes per run (its 8-bit counts); the run loop takes every byte it can.
        const uint8_t avail = static_cast<uint8_t>(rest < 255 ? rest : 255);
        const RunEnd run = take_run(in, avail);
        in += run.taken;
        rest -= run.taken;
        if (run.frame) return FeedResult{DecodeStatus::frame, bytes.size() - rest};
        if (run.taken == avail) continue;
      }
      // What the run loop leaves (errors, resynchronisation) byte by byte: never a data byte that fits
      // when the buffer's room is an 8-bit count too, so then straight to the rare path.
      --rest;
      const DecodeStatus status = Capacity < 255 ? feed_rare(*in++) : feed(*in++);
      if (status != DecodeStatus::more) return FeedResult{status, bytes.size() - rest};
    }
    return FeedResult{DecodeStatus::more, bytes.size()};
  }
  /// After `frame`: the decoded frame (a view into the decoder, valid until the next feed).
  ByteView frame() const { return ByteView(buffer_, size_); }
  /// After `frame`: CRC-16/MCRF4XX of `frame()` from the constructor's `checked_from` on (its initial
  /// value when the frame is not longer than that offset).
  uint16_t checksum() const { return crc_.value(); }
  /// After `error`: why the frame was dropped.
  FrameError error() const { return error_; }
  /// True when the decoder computes a checksum (constructed with a `checked_from` offset).
  bool checked() const { return checked_from_ != kUncheckedIndex; }
  /// The counters it counts into (the layer above counts its own drops there too).
  LinkCounters& counters() const { return *counters_; }
  /// Forgets the frame in progress and waits for the next 0x00.
  void reset() {
    skipping_ = true;
    size_ = 0;
    left_ = 0;
    started_ = false;
  }
  /// Forgets the frame in progress and takes the next byte as a frame's first (code) byte, as a new
  /// decoder would (a partial-frame deadline's drop: the sender may have sent no delimiter before the next).
  void restart() {
    skipping_ = false;
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
  // The `span` bytes from `in` (at most 255) as feed(uint8_t) would take them: data bytes, code bytes (a frame's
  // first, or between blocks with their implied zero stored), delimiters between frames and the one that
  // completes a frame (it stops after that one: `frame`); otherwise it stops at a zero inside a block (bad
  // COBS), a full buffer or the span's end, leaving that byte to feed(uint8_t). Not while skipping. The state stays in registers for
  // the whole run (the CRC too), 8-bit counts (a block holds at most 254 data bytes); out of line so that
  // it gets the registers to itself whatever the caller is.
  // How far take_run went, and whether the delimiter before it completed a frame (returned in registers).
  struct RunEnd {
    uint8_t taken;  // bytes used from `in`
    bool frame;
  };
  __attribute__((noinline)) RunEnd take_run(const uint8_t* in, const uint8_t span) {
    uint8_t avail = span;
    // Few live values (the frame's size as an index, not a second pointer; the runs report what they left,
    // not where they stopped): on the AVR they stay in registers with 9 saved and no stack frame (15 and a
    // frame before).
    const Index checked_from = checked_from_;
    detail::CobsCrc crc = crc_;
    Index at = size_;
    uint8_t* out = buffer_ + at;
    uint8_t left = left_;
    uint8_t last_code = last_code_;
    bool started = started_;
    bool frame = false;
    for (;;) {
      const Index room = static_cast<Index>(Capacity - at);
      uint8_t count = left;
      if (avail < count) count = avail;
      if (room < count) count = static_cast<uint8_t>(room);
      if (count != 0) {
        uint8_t taken;
        uint8_t checked;  // how many go through the CRC run
        if (at >= checked_from) {  // the hot path: a checked decoder past the frame's CRC field
          taken = 0;
          checked = count;
        } else {
          // A decoder without checksum, or a frame's first bytes before the checked offset (its CRC
          // field): copied only, up to that offset; what follows goes through the CRC below (one copy
          // of each run loop in the code: the second one was ~90 B of flash).
          const Index before = static_cast<Index>(checked_from - at);
          const uint8_t unchecked = before < count ? static_cast<uint8_t>(before) : count;
          const uint8_t rest = copy_run(in, out, unchecked);
          taken = static_cast<uint8_t>(unchecked - rest);
          checked = rest != 0 ? 0 : static_cast<uint8_t>(count - unchecked);  // stopped at a zero: none
        }
        if (checked != 0) taken = static_cast<uint8_t>(taken + checked - checked_run(in, out, checked, crc));
        avail = static_cast<uint8_t>(avail - taken);
        at = static_cast<Index>(at + taken);
        left = static_cast<uint8_t>(left - taken);
      }
      if (left != 0 || avail == 0) break;  // a zero inside the block, a full buffer, or all used
      const uint8_t code = *in;
      if (code == 0x00) {
        ++in;
        --avail;
        if (started) {  // completes the frame (end_frame's case of a frame)
          started = false;
          frame = true;
          break;
        }
        at = 0;  // a delimiter between frames (end_frame without a frame): size 0
        out = buffer_;
        continue;
      }
      if (!started) {  // a frame's first code byte; the previous frame stayed readable until now
        started = true;
        at = 0;
        out = buffer_;
        crc.reset();
      } else if (last_code != 0xFF) {  // the zero that ended the previous block
        if (at == Capacity) break;     // feed(uint8_t) drops the frame
        if (at >= checked_from) crc.update(0x00);
        *out++ = 0x00;
        ++at;
      }
      last_code = code;
      left = static_cast<uint8_t>(code - 1);
      ++in;
      --avail;
    }
    crc_ = crc;
    left_ = left;
    last_code_ = last_code;
    started_ = started;
    size_ = at;
    return RunEnd{static_cast<uint8_t>(span - avail), frame};
  }
  // Copies up to `count` (>= 1) bytes from `in` to `out`, stopping at a zero; advances both past what it
  // copied (`in` then points at the zero) and returns how many of `count` it did not copy (0: all). The
  // run loop of a decoder without checksum.
  __attribute__((always_inline)) static uint8_t copy_run(const uint8_t*& in, uint8_t*& out, uint8_t count) {
#if defined(__AVR__)
    // X and Z post-increments (avr-gcc 5.4 recomputed both pointers every byte: 15 cycles a byte, now 9).
    // Local copies of the pointers: through the references avr-gcc 5.4 gave the caller a stack frame.
    const uint8_t* from = in;
    uint8_t* to = out;
    uint8_t byte;
    __asm__ volatile(
        "1:  ld   %[byte], X+\n\t"
        "    tst  %[byte]\n\t"
        "    breq 2f\n\t"
        "    st   Z+, %[byte]\n\t"
        "    dec  %[count]\n\t"
        "    brne 1b\n\t"
        "    rjmp 3f\n\t"
        "2:  sbiw r26, 1\n\t"  // back to the zero
        "3:\n\t"
        : [in] "+x"(from), [out] "+z"(to), [count] "+r"(count), [byte] "=&r"(byte)
        :
        : "memory");
    in = from;
    out = to;
#else
    do {
      const uint8_t byte = *in;
      if (byte == 0x00) break;
      ++in;
      *out++ = byte;
    } while (--count != 0);
#endif
    return count;
  }
  // Copies up to `count` (>= 1) bytes from `in` to `out` through `crc`, stopping at a zero; advances both
  // past what it copied (`in` then points at the zero) and returns how many of `count` it did not copy
  // (0: all). The decoder's hot loop.
  __attribute__((always_inline)) static uint8_t checked_run(const uint8_t*& in, uint8_t*& out, uint8_t count,
                                                            detail::CobsCrc& crc) {
#if defined(__AVR__)
    // avr-gcc 5.4 keeps neither pointer in a post-increment register through this loop (29..33 cycles a
    // byte, measured): hand-placed X and Z post-increments. The CRC step is Crc16Mcrf4xx's on the register
    // (the documented CCITT byte step: d = byte ^ lo, d ^= d << 4, crc = (d << 8 | hi) ^ d >> 4 ^ d << 3)
    // with the hardware multiplier doing the shifts: `mul d, 16` gives d << 4 and `mul d, 8` gives the
    // 16-bit d << 3 in r1:r0 at once, 12 cycles where avr-libc's shift-and-mask `_crc_ccitt_update` takes
    // 17: 20.5 cycles a byte (26 before). r1 (the zero register) is cleared again on the way out.
    uint16_t state = crc.state;
    const uint8_t* from = in;
    uint8_t* to = out;
    uint8_t byte;
    uint8_t sixteen;
    uint8_t eight;
    __asm__ volatile(
        "    ldi  %[sixteen], 16\n\t"
        "    mov  %[eight], %[sixteen]\n\t"
        "    lsr  %[eight]\n\t"
        // Two bytes a turn: the first leaves the new low byte in the high register and the new high
        // byte in the low one (no `mov` to put them back), the second steps with the roles swapped and
        // leaves them where they were. An exit after the first swaps them back.
        "1:  ld   %[byte], X+\n\t"
        "    tst  %[byte]\n\t"
        "    breq 5f\n\t"
        "    st   Z+, %[byte]\n\t"
        "    eor  %[byte], %A[state]\n\t"   // d = byte ^ lo
        "    mul  %[byte], %[sixteen]\n\t"
        "    eor  %[byte], r0\n\t"          // d ^= d << 4
        "    mul  %[byte], %[eight]\n\t"    // r1:r0 = d << 3
        "    eor  %B[state], r0\n\t"        // new lo (in the high register) = hi ^ (d << 3) & 0xFF ...
        "    mov  %A[state], %[byte]\n\t"
        "    eor  %A[state], r1\n\t"        // new hi (in the low register) = d ^ (d << 3) >> 8
        "    swap %[byte]\n\t"
        "    andi %[byte], 0x0F\n\t"
        "    eor  %B[state], %[byte]\n\t"   // ... ^ d >> 4
        "    dec  %[count]\n\t"
        "    breq 6f\n\t"
        "    ld   %[byte], X+\n\t"
        "    tst  %[byte]\n\t"
        "    breq 7f\n\t"
        "    st   Z+, %[byte]\n\t"
        "    eor  %[byte], %B[state]\n\t"   // the same step, roles swapped
        "    mul  %[byte], %[sixteen]\n\t"
        "    eor  %[byte], r0\n\t"
        "    mul  %[byte], %[eight]\n\t"
        "    eor  %A[state], r0\n\t"
        "    mov  %B[state], %[byte]\n\t"
        "    eor  %B[state], r1\n\t"
        "    swap %[byte]\n\t"
        "    andi %[byte], 0x0F\n\t"
        "    eor  %A[state], %[byte]\n\t"
        "    dec  %[count]\n\t"
        "    brne 1b\n\t"
        "    rjmp 8f\n\t"
        "7:  sbiw r26, 1\n\t"  // back to the zero
        "6:  mov  r0, %A[state]\n\t"        // roles back
        "    mov  %A[state], %B[state]\n\t"
        "    mov  %B[state], r0\n\t"
        "    rjmp 8f\n\t"
        "5:  sbiw r26, 1\n\t"  // back to the zero
        "8:  clr  __zero_reg__\n\t"
        : [in] "+x"(from), [out] "+z"(to), [state] "+r"(state), [count] "+r"(count), [byte] "=&d"(byte),
          [sixteen] "=&d"(sixteen), [eight] "=&r"(eight)
        :
        : "r0", "memory");
    in = from;
    out = to;
    crc.state = state;
#else
    do {
      const uint8_t byte = *in;
      if (byte == 0x00) break;
      ++in;
      crc.update(byte);
      *out++ = byte;
    } while (--count != 0);
#endif
    return count;
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

  // The state first, the buffer last: on the AVR the run loop reaches every state member as `this` plus a
  // displacement (ldd/std take up to 63); behind a 66-byte buffer each needed its own pointer register
  // (saved and restored: 18 registers and a stack frame where 9 do).
  LinkCounters* counters_;
  Index size_ = 0;
  Index checked_from_;      // first decoded byte the checksum covers (kUnchecked: none)
  uint8_t left_ = 0;        // data bytes left in the current block (0 while skipping)
  uint8_t last_code_ = 0;   // code of the current block
  bool started_ = false;    // a code byte was seen since the last delimiter
  bool skipping_ = false;   // after an error: ignore bytes until the next 0x00
  FrameError error_ = FrameError::none;
  detail::CobsCrc crc_;
  uint8_t buffer_[Capacity];
};

}  // namespace proxy
}  // namespace tether
