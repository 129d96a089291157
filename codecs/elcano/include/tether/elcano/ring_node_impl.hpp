// Implementation of ring_node.hpp (a template: the buffer sizes are the user's choice).
#pragma once

namespace tether {
namespace elcano {

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
bool RingNode<MessageCapacity, OutputCapacity, OriginSlots>::enqueue(ByteView bytes) {
  if (bytes.size() > output_room()) return false;
  for (size_t i = 0; i < bytes.size(); ++i) {
    queue_[head_ & (OutputCapacity - 1)] = bytes[i];
    head_ = static_cast<uint8_t>(head_ + 1);
  }
  return true;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
bool RingNode<MessageCapacity, OutputCapacity, OriginSlots>::came_back(ByteView stripped) {
  // The records first: a node that originates nothing skips the length check too.
  if (origins_used_ == 0) return false;
  if (stripped.size() > 255) return false;
  const uint8_t length = static_cast<uint8_t>(stripped.size());
  // The CRC only when a record of that length exists: most traffic through a node is not its own.
  bool candidate = false;
  for (const Origin& origin : origins_) candidate = candidate || (origin.used && origin.length == length);
  if (!candidate) return false;
  const uint16_t crc = signature_crc(stripped);
  // The oldest matching record: the same bytes sent twice come back in order.
  Origin* oldest = nullptr;
  for (Origin& origin : origins_) {
    if (!origin.used || origin.length != length || origin.crc != crc) continue;
    if (oldest == nullptr || tick_difference(origin.expires.at(), oldest->expires.at()) < 0) oldest = &origin;
  }
  if (oldest == nullptr) return false;
  oldest->used = false;
  --origins_used_;
  return true;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent::Kind RingNode<MessageCapacity, OutputCapacity, OriginSlots>::consume(uint8_t byte, Millis now) {
  return on_read(reader_.feed(byte), now);
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent::Kind RingNode<MessageCapacity, OutputCapacity, OriginSlots>::consume(ByteView bytes, Millis now,
                                                                                 size_t& consumed) {
  const FeedResult read = reader_.feed(bytes);
  consumed = read.consumed;
  // The deadline is followed once for the span, not per byte: every byte has the same `now`, and a span
  // ends at the byte of an event, so the open/closed changes inside it come out as they would byte by byte.
  return on_read(read.status, now);
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent::Kind RingNode<MessageCapacity, OutputCapacity, OriginSlots>::on_read(DecodeStatus read, Millis now) {
  // The partial-message deadline follows the reader: armed when a message starts, off when none is open.
  if (reader_.in_frame()) {
    if (!partial_.in_frame()) partial_.on_frame_start(now);
  } else {
    partial_.on_frame_end();
  }
  if (read == DecodeStatus::more) return RingEvent::Kind::none;
  if (read == DecodeStatus::error) {
    error_ = reader_.error();
    return RingEvent::Kind::dropped;
  }
  const ByteView forward = reader_.forward();
  if (came_back(forward)) {
    add_one(counters_->undeliverable);
    return RingEvent::Kind::undeliverable;
  }
  if (config_.capture.contains(reader_.frame().type)) {
    add_one_in_interrupt(counters_->captured);  // the carry loop inline: ~10 AVR cycles, `++` ~24
    return RingEvent::Kind::captured;
  }
  if (!enqueue(forward)) {
    add_one(counters_->queue_full_drops);
    error_ = Error::queue_full;
    return RingEvent::Kind::dropped;
  }
  ++counters_->forwarded;
  return RingEvent::Kind::forwarded;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent RingNode<MessageCapacity, OutputCapacity, OriginSlots>::feed(uint8_t byte, Millis now) {
  return event(consume(byte, now));
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent RingNode<MessageCapacity, OutputCapacity, OriginSlots>::event(RingEvent::Kind kind) const {
  RingEvent event;
  event.kind = kind;
  if (kind == RingEvent::Kind::dropped) event.error = error_;
  // A message dropped for a full queue was read whole: it is reported too.
  const bool has_message =
      kind != RingEvent::Kind::none && (kind != RingEvent::Kind::dropped || error_ == Error::queue_full);
  if (has_message) event.message = reader_.frame();
  return event;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
Status RingNode<MessageCapacity, OutputCapacity, OriginSlots>::originate(const Message& message, Millis now) {
  uint8_t bytes[MessageCapacity];
  const Result<size_t> written = encode_message(message, config_.generation, MutableByteView(bytes, sizeof bytes));
  if (!written.ok()) return written.status() == Status::buffer_too_small ? Status::invalid_argument : written.status();
  if (written.value() + MessageCapacity > output_room()) return Status::busy;  // keep the forwarding reserve
  // The signature covers the bytes as they come back: forwarded copies are whitespace-stripped.
  uint8_t stripped[MessageCapacity];
  size_t stripped_size = 0;
  for (size_t i = 0; i < written.value(); ++i) {
    if (bytes[i] != ' ') stripped[stripped_size++] = bytes[i];
  }
  // Take a free record, else the oldest (counted: its message can no longer be recognised).
  Origin* slot = nullptr;
  for (Origin& origin : origins_) {
    if (!origin.used) {
      slot = &origin;
      break;
    }
    if (slot == nullptr || tick_difference(origin.expires.at(), slot->expires.at()) < 0) slot = &origin;
  }
  if (slot->used) {
    add_one(counters_->origins_evicted);
  } else {
    ++origins_used_;
  }
  slot->used = true;
  slot->length = static_cast<uint8_t>(stripped_size);
  slot->crc = signature_crc(ByteView(stripped, stripped_size));
  slot->expires.arm(now, config_.return_timeout);
  enqueue(ByteView(bytes, written.value()));
  ++counters_->originated;
  return Status::ok;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
size_t RingNode<MessageCapacity, OutputCapacity, OriginSlots>::take_output(MutableByteView out, Millis now) {
  size_t count = pending_output();
  if (count > out.size()) count = out.size();
  count = pacer_.take(static_cast<uint16_t>(count), now);  // the queue holds fewer than 2^16 bytes
  for (size_t i = 0; i < count; ++i) {
    out[i] = queue_[tail_ & (OutputCapacity - 1)];
    tail_ = static_cast<uint8_t>(tail_ + 1);
  }
  return count;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
RingEvent RingNode<MessageCapacity, OutputCapacity, OriginSlots>::poll(Millis now) {
  RingEvent event;
  if (partial_.poll(now)) {
    reader_.reset();
    event.kind = RingEvent::Kind::dropped;
    event.error = Error::timed_out;
    return event;
  }
  if (origins_used_ == 0) return event;
  for (Origin& origin : origins_) {
    if (origin.used && origin.expires.expired(now)) {
      origin.used = false;
      --origins_used_;
      add_one(counters_->origins_expired);
    }
  }
  return event;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
Deadline RingNode<MessageCapacity, OutputCapacity, OriginSlots>::next_wakeup(Millis now, bool include_output) {
  Deadline earliest = partial_.deadline();
  const auto consider = [&earliest](Millis at) {
    if (!earliest.armed() || tick_difference(at, earliest.at()) < 0) earliest.arm_at(at);
  };
  for (const Origin& origin : origins_) {
    if (origin.used) consider(origin.expires.at());
  }
  const size_t pending = include_output ? pending_output() : 0;
  if (pending != 0) {
    const uint16_t chunk = static_cast<uint16_t>(pending < pacer_.depth() ? pending : pacer_.depth());
    consider(pacer_.next_allowed(chunk, now));
  }
  return earliest;
}

template <size_t MessageCapacity, size_t OutputCapacity, uint8_t OriginSlots>
void RingNode<MessageCapacity, OutputCapacity, OriginSlots>::reset() {
  reader_.reset();
  partial_.on_frame_end();
  head_ = 0;
  tail_ = 0;
  for (Origin& origin : origins_) origin.used = false;
  origins_used_ = 0;
}

}  // namespace elcano
}  // namespace tether
