// Implementation of envelope_decoder.hpp (a template: the capacity differs on host and device).
#pragma once

#include "tether/core/crc.hpp"
#include "tether/romi/encoder.hpp"

namespace tether {
namespace romi {
namespace detail {

/// Value of a lowercase hex digit, or -1 (uppercase is rejected, as by the reference).
inline int8_t hex_value(uint8_t c) {
  if (c >= '0' && c <= '9') return static_cast<int8_t>(c - '0');
  if (c >= 'a' && c <= 'f') return static_cast<int8_t>(c - 'a' + 10);
  return -1;
}

}  // namespace detail

template <size_t Capacity>
EnvelopeEvent EnvelopeDecoder<Capacity>::feed(uint8_t byte) {
  if (byte == '#') {
    // A new frame starts anywhere; whatever came before it is dropped.
    if (state_ == State::body || state_ == State::expect_lf || skipping_) ++counters_->resyncs;
    skipping_ = false;
    state_ = State::body;
    size_ = 0;
    seen_colon_ = false;
    pending_ = EnvelopeEvent();  // nothing of the previous frame (its id!) may leak into this one
    return EnvelopeEvent();
  }
  switch (state_) {
    case State::idle:
    case State::skip:
      skipping_ = true;
      return EnvelopeEvent();
    case State::body:
      if (byte == '\r' || byte == '\n') return finish_line(byte);
      if (size_ == Capacity) return fail(ErrorCode::envelope_too_long);
      if (byte == ':') {
        seen_colon_ = true;
        last_colon_ = size_;
      }
      buffer_[size_++] = byte;
      return EnvelopeEvent();
    case State::expect_lf:
      if (byte != '\n') return fail(ErrorCode::expected_end);
      state_ = State::idle;
      ++counters_->frames_ok;
      return pending_;
  }
  return EnvelopeEvent();
}

template <size_t Capacity>
EnvelopeEvent EnvelopeDecoder<Capacity>::finish_line(uint8_t end) {
  if (!seen_colon_) return fail(ErrorCode::missing_metadata);
  const uint8_t* meta = buffer_ + last_colon_ + 1;
  const size_t meta_size = size_ - last_colon_ - 1;
  pending_ = EnvelopeEvent();
  if (meta_size > 0 && meta[0] == 'x') {
    // Manual frame: exactly "xxxx".
    for (size_t i = 0; i < 4; ++i) {
      if (i >= meta_size || meta[i] != 'x') return fail(ErrorCode::invalid_dummy_metadata);
    }
    pending_.manual = true;
  } else {
    const int8_t id_high = meta_size > 0 ? detail::hex_value(meta[0]) : -1;
    const int8_t id_low = meta_size > 1 ? detail::hex_value(meta[1]) : -1;
    if (id_high < 0 || id_low < 0) return fail(ErrorCode::invalid_id);
    pending_.has_id = true;
    pending_.id = static_cast<uint8_t>((id_high << 4) | id_low);
    const int8_t crc_high = meta_size > 2 ? detail::hex_value(meta[2]) : -1;
    const int8_t crc_low = meta_size > 3 ? detail::hex_value(meta[3]) : -1;
    if (crc_high < 0 || crc_low < 0) return fail(ErrorCode::invalid_crc);
    if (meta_size == 4) {
      Crc8Smbus crc;
      crc.update('#');
      crc.update(ByteView(buffer_, last_colon_ + 3));  // payload, ':' and the id
      if (crc.value() != static_cast<uint8_t>((crc_high << 4) | crc_low)) {
        ++counters_->crc_errors;
        return fail(ErrorCode::crc_mismatch);
      }
    }
  }
  // A fifth metadata character, or '\n' without '\r': the frame did not end where it must.
  if (meta_size > 4 || end != '\r') return fail(ErrorCode::expected_end);
  const bool is_log = last_colon_ > 0 && buffer_[0] == '!';
  pending_.kind = is_log ? EnvelopeEvent::Kind::log : EnvelopeEvent::Kind::frame;
  pending_.payload = is_log ? ByteView(buffer_ + 1, last_colon_ - 1) : ByteView(buffer_, last_colon_);
  pending_.opcode = !is_log && last_colon_ > 0 && is_opcode(buffer_[0]) ? static_cast<char>(buffer_[0]) : '_';
  state_ = State::expect_lf;
  return EnvelopeEvent();
}

template <size_t Capacity>
EnvelopeEvent EnvelopeDecoder<Capacity>::fail(ErrorCode code) {
  EnvelopeEvent event;
  event.kind = EnvelopeEvent::Kind::error;
  event.error = code;
  event.opcode = size_ > 0 && is_opcode(buffer_[0]) ? static_cast<char>(buffer_[0]) : '_';
  event.log_line = size_ > 0 && buffer_[0] == '!';
  if (state_ == State::expect_lf || pending_.has_id) {
    event.has_id = pending_.has_id;
    event.id = pending_.id;
  }
  if (code == ErrorCode::envelope_too_long) {
    ++counters_->oversize_frames;
  } else if (code != ErrorCode::crc_mismatch) {
    ++counters_->framing_errors;
  }
  state_ = State::skip;
  pending_ = EnvelopeEvent();
  return event;
}

}  // namespace romi
}  // namespace tether
