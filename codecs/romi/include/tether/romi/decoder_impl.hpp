// Implementation of decoder.hpp (a template: the capacity differs on host and device).
#pragma once

#include "tether/core/crc.hpp"
#include "tether/romi/encoder.hpp"

namespace tether {
namespace romi {
namespace detail {

/// Value of a lowercase hex digit, or -1 (uppercase is rejected, as by the reference).
__attribute__((always_inline)) inline int8_t hex_value(uint8_t c) {
  if (c >= '0' && c <= '9') return static_cast<int8_t>(c - '0');
  if (c >= 'a' && c <= 'f') return static_cast<int8_t>(c - 'a' + 10);
  return -1;
}

}  // namespace detail

template <size_t Capacity, typename Counters>
__attribute__((always_inline)) inline bool Decoder<Capacity, Counters>::feed_body(uint8_t byte) {
  // The common case, a byte inside a frame's body, stays small enough to inline into the caller's byte
  // loop without a stack frame; everything else (frame start and end, errors) is out of line.
  const Index size = size_;
  if (state_ != State::body || byte == '#' || byte == '\r' || byte == '\n' || size == buffer_.capacity()) return false;
  if (byte == ':') {
    seen_colon_ = true;
    last_colon_ = size;
  }
  buffer_.data()[size] = byte;
  size_ = static_cast<Index>(size + 1u);
  return true;
}

template <size_t Capacity, typename Counters>
__attribute__((always_inline)) inline uint8_t Decoder<Capacity, Counters>::feed_body_run(const uint8_t* bytes, uint8_t count) {
  if (state_ != State::body) return 0;
  const Index size = size_;
  const Index room = static_cast<Index>(buffer_.capacity() - size);  // a full buffer ends the run: feed_special says -1
  uint8_t left = count < room ? count : static_cast<uint8_t>(room);
  const uint8_t* in = bytes;
  uint8_t* const start = buffer_.data();
  uint8_t* out = start + size;
#if defined(__AVR__)
  if (sizeof(Index) == 1 && left != 0) {
    // The same loop in assembly: 11 cycles a usual byte, where avr-gcc's took 17 (it moved the input
    // pointer between registers twice a byte). The last ':' of the run is noted by the low byte of its
    // position's address (the buffer is at most 255 bytes: the difference of the low bytes is the offset).
    uint8_t byte;
    uint8_t colon = 0;
    uint8_t seen = 0;
    __asm__ volatile(
        "1: ld %[byte], Z+\n\t"
        "cpi %[byte], 0x24\n\t"  // every special byte is at most '#' (0x23)
        "brlo 4f\n\t"
        "cpi %[byte], ':'\n\t"
        "breq 5f\n"
        "2: st X+, %[byte]\n\t"
        "dec %[left]\n\t"
        "brne 1b\n\t"
        "rjmp 7f\n"
        "4: cpi %[byte], '#'\n\t"
        "breq 6f\n\t"
        "cpi %[byte], '\\r'\n\t"
        "breq 6f\n\t"
        "cpi %[byte], '\\n'\n\t"
        "brne 2b\n"
        "6: sbiw %[in], 1\n\t"  // the special byte stays for the caller
        "rjmp 7f\n"
        "5: mov %[colon], %A[out]\n\t"
        "ldi %[seen], 1\n\t"
        "rjmp 2b\n"
        "7:"
        : [in] "+z"(in), [out] "+x"(out), [left] "+r"(left), [byte] "=&r"(byte), [colon] "+r"(colon),
          [seen] "+d"(seen)
        :
        : "memory");
    if (seen != 0) {
      seen_colon_ = true;
      last_colon_ = static_cast<Index>(colon - static_cast<uint8_t>(reinterpret_cast<uintptr_t>(start)));
    }
    left = 0;
  }
#endif
  for (; left != 0; --left) {
    const uint8_t byte = *in;
    // One compare for the usual bytes: every special one is at most '#' (0x23).
    if (byte <= '#' && (byte == '#' || byte == '\r' || byte == '\n')) break;
    if (byte == ':') {
      seen_colon_ = true;
      last_colon_ = static_cast<Index>(out - start);
    }
    *out++ = byte;
    ++in;
  }
  const uint8_t used = static_cast<uint8_t>(in - bytes);
  size_ = static_cast<Index>(size + used);
  return used;
}

template <size_t Capacity, typename Counters>
__attribute__((always_inline)) inline DecodeStatus Decoder<Capacity, Counters>::feed(uint8_t byte) {
  return feed_body(byte) ? DecodeStatus::more : feed_special(byte);
}

template <size_t Capacity, typename Counters>
FeedResult Decoder<Capacity, Counters>::feed(ByteView bytes) {
  const uint8_t* const begin = bytes.data();
  const uint8_t* const end = begin + bytes.size();
  const uint8_t* next = begin;
  while (next != end) {
    // A frame's body bytes in runs (at most 255 at a time: feed_body_run counts in 8 bits); the byte that
    // ends a run goes through feed(byte), with the members in step.
    const size_t left = static_cast<size_t>(end - next);
    next += feed_body_run(next, static_cast<uint8_t>(left < 255u ? left : 255u));
    if (next == end) break;
    const DecodeStatus status = feed(*next++);
    if (status != DecodeStatus::more) return FeedResult{status, static_cast<size_t>(next - begin)};
  }
  return FeedResult{DecodeStatus::more, bytes.size()};
}

template <size_t Capacity, typename Counters>
char Decoder<Capacity, Counters>::partial_opcode() const {
  return in_frame() && size_ > 0 && is_opcode(buffer_.data()[0]) ? static_cast<char>(buffer_.data()[0]) : '_';
}

template <size_t Capacity, typename Counters>
__attribute__((always_inline)) inline void Decoder<Capacity, Counters>::feed_hash() {
  // A new frame starts anywhere; whatever came before it is dropped.
  if (state_ == State::body || state_ == State::expect_lf || skipping_) add_one(counters_->resyncs);
  skipping_ = false;
  state_ = State::body;
  size_ = 0;
  seen_colon_ = false;
  // Nothing of the previous frame (its id!) may leak into this one: the fields that finish_line and
  // fail() may leave as they are. Both write the payload, the log flag and the opcode before any status
  // shows the frame (6 stores less on a device's every request). Field by field: assigning a fresh
  // Frame() builds a temporary on the AVR's stack first.
  frame_.manual = false;
  frame_.has_id = false;
  frame_.id = 0;
}

template <size_t Capacity, typename Counters>
DecodeStatus Decoder<Capacity, Counters>::feed_special(uint8_t byte) {
  if (byte == '#') {
    feed_hash();
    return DecodeStatus::more;
  }
  switch (state_) {
    case State::idle:
    case State::skip:
      skipping_ = true;
      return DecodeStatus::more;
    case State::body:
      if (byte == '\r' || byte == '\n') return finish_line(byte);
      if (size_ == buffer_.capacity()) return fail(Error::envelope_too_long);
      if (byte == ':') {
        seen_colon_ = true;
        last_colon_ = size_;
      }
      buffer_.data()[size_] = byte;
      size_ = static_cast<Index>(size_ + 1u);
      return DecodeStatus::more;
    case State::expect_lf:
      if (byte != '\n') return fail(Error::expected_end);
      state_ = State::idle;
      add_one_inline(counters_->frames_ok);  // every request's: inline (add_one's call costs ~25 cycles on the AVR)
      return DecodeStatus::frame;
  }
  return DecodeStatus::more;
}

template <size_t Capacity, typename Counters>
DecodeStatus Decoder<Capacity, Counters>::finish_line(uint8_t end) {
  if (!seen_colon_) return fail(Error::missing_metadata);
  const uint8_t* const buffer = buffer_.data();
  const uint8_t* meta = buffer + last_colon_ + 1;
  const Index meta_size = static_cast<Index>(size_ - last_colon_ - 1);
  if (meta_size > 0 && meta[0] == 'x') {
    // Manual frame: exactly "xxxx".
    for (uint8_t i = 0; i < 4; ++i) {
      if (i >= meta_size || meta[i] != 'x') return fail(Error::invalid_dummy_metadata);
    }
    frame_.manual = true;
  } else {
    const int8_t id_high = meta_size > 0 ? detail::hex_value(meta[0]) : -1;
    const int8_t id_low = meta_size > 1 ? detail::hex_value(meta[1]) : -1;
    if (id_high < 0 || id_low < 0) return fail(Error::invalid_id);
    frame_.has_id = true;
    frame_.id = static_cast<uint8_t>((id_high << 4) | id_low);
    const int8_t crc_high = meta_size > 2 ? detail::hex_value(meta[2]) : -1;
    const int8_t crc_low = meta_size > 3 ? detail::hex_value(meta[3]) : -1;
    if (crc_high < 0 || crc_low < 0) return fail(Error::invalid_crc);
    if (meta_size == 4) {
      Crc8Smbus crc;
      crc.update('#');
#if defined(__AVR__)
      // Payload, ':' and the id, counted down in the index's width: with a pointer to the end instead,
      // avr-gcc keeps the buffer's address in the table's Z and moves it out and back for every byte.
      const uint8_t* next = buffer;
      for (Index left = static_cast<Index>(last_colon_ + 3u); left != 0; --left) crc.update(*next++);
#else
      crc.update(ByteView(buffer, last_colon_ + 3u));  // payload, ':' and the id
#endif
      if (crc.value() != static_cast<uint8_t>((crc_high << 4) | crc_low)) {
        add_one(counters_->crc_errors);
        return fail(Error::crc_mismatch);
      }
    }
  }
  // A fifth metadata character, or '\n' without '\r': the frame did not end where it must.
  if (meta_size > 4 || end != '\r') return fail(Error::expected_end);
  const bool is_log = last_colon_ > 0 && buffer[0] == '!';
  frame_.log = is_log;
  frame_.payload = is_log ? ByteView(buffer + 1, last_colon_ - 1u) : ByteView(buffer, last_colon_);
  frame_.opcode = !is_log && last_colon_ > 0 && is_opcode(buffer[0]) ? static_cast<char>(buffer[0]) : '_';
  state_ = State::expect_lf;
  return DecodeStatus::more;
}

template <size_t Capacity, typename Counters>
DecodeStatus Decoder<Capacity, Counters>::fail(Error error) {
  error_ = static_cast<int8_t>(error);
  // What was parsed: the opcode character, whether it was a log line, and the id only when its two
  // digits were valid (has_id and id as finish_line left them; the frame's '#' cleared both), never a
  // manual flag. Field by field: assigning a fresh Frame() builds a temporary on the AVR's stack.
  frame_.payload = ByteView();
  frame_.manual = false;
  frame_.opcode = partial_opcode();
  frame_.log = size_ > 0 && buffer_.data()[0] == '!';
  if (error == Error::envelope_too_long) {
    add_one(counters_->oversize_frames);
  } else if (error != Error::crc_mismatch) {
    add_one(counters_->framing_errors);
  }
  state_ = State::skip;
  return DecodeStatus::error;
}

}  // namespace romi
}  // namespace tether
