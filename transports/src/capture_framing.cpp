// Cutting a link's bytes into frame and unframed packets (capture_framing.hpp).
#include "tether/transports/capture_framing.hpp"

#include <stdexcept>
#include <utility>

namespace tether::transports {

DelimitedFramer::DelimitedFramer(DelimitedFraming framing) : framing_(std::move(framing)) {
  if (framing_.max_frame == 0) throw std::invalid_argument("DelimitedFraming: max_frame must be at least 1");
}

bool DelimitedFramer::starts(std::uint8_t byte) const {
  return framing_.start.empty() ? byte != framing_.end
                                : framing_.start.find(static_cast<char>(byte)) != std::string::npos;
}

void DelimitedFramer::emit_unframed(const PacketSink& sink) {
  if (unframed_.empty()) return;
  FramedPacket packet;
  packet.bytes = std::move(unframed_);
  packet.frame = false;
  packet.reason = unframed_reason_;
  unframed_.clear();
  sink(std::move(packet));
}

void DelimitedFramer::add_unframed(std::uint8_t byte, const std::string& reason, const PacketSink& sink) {
  if (!unframed_.empty() && reason != unframed_reason_) emit_unframed(sink);
  unframed_reason_ = reason;
  unframed_.push_back(byte);
  if (unframed_.size() >= framing_.max_frame) emit_unframed(sink);  // bounded runs
}

void DelimitedFramer::feed(std::span<const std::uint8_t> bytes, const PacketSink& sink) {
  static const std::string kNoise = "noise";
  static const std::string kTooLong = "too long";
  static const std::string kCut = "cut by a new frame";
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const std::uint8_t byte = bytes[i];
    switch (state_) {
      case State::idle:
        if (framing_.leading_end_bytes && byte == framing_.end) {
          emit_unframed(sink);
          frame_.assign(1, byte);
          state_ = State::leading;
        } else if (starts(byte)) {
          emit_unframed(sink);
          frame_.assign(1, byte);
          state_ = State::frame;
        } else {
          add_unframed(byte, kNoise, sink);
        }
        break;
      case State::leading:
        if (byte == framing_.end) {
          if (frame_.size() + 1 >= framing_.max_frame) {  // a long run of delimiters: noise, bounded
            for (const std::uint8_t each : frame_) add_unframed(each, kNoise, sink);
            frame_.clear();
          }
          frame_.push_back(byte);
        } else if (starts(byte)) {
          frame_.push_back(byte);
          state_ = State::frame;
        } else {
          for (const std::uint8_t each : frame_) add_unframed(each, kNoise, sink);
          frame_.clear();
          state_ = State::idle;
          --i;  // look at this byte again, from idle
        }
        break;
      case State::frame:
        if (byte == framing_.end) {
          frame_.push_back(byte);
          FramedPacket packet;
          packet.bytes = std::move(frame_);
          frame_.clear();
          state_ = State::idle;
          sink(std::move(packet));
        } else if (framing_.restart_on_start && starts(byte)) {
          for (const std::uint8_t each : frame_) add_unframed(each, kCut, sink);
          emit_unframed(sink);
          frame_.assign(1, byte);
        } else if (frame_.size() + 1 >= framing_.max_frame) {
          // No room left for this byte and the end byte: the frame is too long.
          for (const std::uint8_t each : frame_) add_unframed(each, kTooLong, sink);
          frame_.clear();
          add_unframed(byte, kTooLong, sink);
          state_ = State::skipping;
        } else {
          frame_.push_back(byte);
        }
        break;
      case State::skipping:
        if (byte == framing_.end) {
          add_unframed(byte, kTooLong, sink);
          emit_unframed(sink);
          state_ = State::idle;
        } else if (framing_.restart_on_start && starts(byte)) {
          emit_unframed(sink);
          frame_.assign(1, byte);
          state_ = State::frame;
        } else {
          add_unframed(byte, kTooLong, sink);
        }
        break;
    }
  }
}

void DelimitedFramer::flush(std::string_view reason, const PacketSink& sink) {
  emit_unframed(sink);
  if (!frame_.empty()) {
    const std::string why(reason);
    for (const std::uint8_t each : frame_) add_unframed(each, why, sink);
    frame_.clear();
    emit_unframed(sink);
  }
  state_ = State::idle;
}

void ChunkFramer::feed(std::span<const std::uint8_t> bytes, const PacketSink& sink) {
  if (bytes.empty()) return;
  FramedPacket packet;
  packet.bytes.assign(bytes.begin(), bytes.end());
  packet.frame = false;
  packet.reason = "no framing";
  sink(std::move(packet));
}

}  // namespace tether::transports
