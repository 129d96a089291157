#include "fake_device.hpp"

#include <atomic>
#include <cstdio>
#include <vector>

namespace tether::proxy::testing {

std::shared_ptr<FakeDevice> FakeDevice::start(std::shared_ptr<transports::ByteStream> end, Integrity integrity,
                                              Script script, std::shared_ptr<client::LinkClock> clock) {
  auto device = std::make_shared<FakeDevice>(std::move(end), integrity, std::move(clock));
  device->on_frame(std::move(script));
  device->ScriptedPeer::start();
  return device;
}

FakeDevice::FakeDevice(std::shared_ptr<transports::ByteStream> end, Integrity integrity,
                       std::shared_ptr<client::LinkClock> clock)
    : ScriptedDevice(std::move(end)),
      integrity_(integrity),
      clock_(clock ? std::move(clock) : client::steady_link_clock()),
      decoder_(integrity, counters_) {}

std::string FakeDevice::frame_bytes(const std::string& payload, Integrity integrity) {
  std::vector<std::uint8_t> out(max_frame_size(payload.size()));
  const auto size = encode_frame(ByteView::from_chars(payload.data(), payload.size()), integrity, false,
                                 MutableByteView(out.data(), out.size()));
  return std::string(reinterpret_cast<const char*>(out.data()), size.ok() ? size.value() : 0);
}

std::string FakeDevice::frame(const ArduinoOut& out) { return frame_bytes(out.SerializeAsString(), Integrity::crc16); }

std::string FakeDevice::ack(std::uint32_t message_id, bool refused) {
  ArduinoOut out;
  out.mutable_ack()->set_messageid(message_id);
  out.mutable_ack()->set_refused(refused);
  return frame(out);
}

std::string FakeDevice::reset_event(std::uint32_t session_id) {
  ArduinoOut out;
  out.mutable_resetevent()->set_sessionid(session_id);
  return frame(out);
}

std::string FakeDevice::info(std::uint32_t session_id, bool failsafe) {
  ArduinoOut out;
  out.mutable_info()->set_sessionid(session_id);
  out.mutable_info()->set_pingfailsafetriggered(failsafe);
  return frame(out);
}

std::string FakeDevice::error(const std::string& text, Error::Level level) {
  ArduinoOut out;
  out.mutable_error()->set_text(text);
  out.mutable_error()->set_level(level);
  return frame(out);
}

std::string FakeDevice::pin_state(std::uint32_t pin, std::int32_t value, bool failsafe) {
  ArduinoOut out;
  out.mutable_pinstate()->set_pin(pin);
  out.mutable_pinstate()->set_value(value);
  out.mutable_pinstate()->set_failsafe(failsafe);
  return frame(out);
}

void FakeDevice::on_bytes(const std::uint8_t* data, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint8_t byte = data[i];
    frame_.push_back(static_cast<char>(byte));
    const DecodeStatus status = decoder_.feed(byte);
    if (status == DecodeStatus::more) {
      if (byte == 0x00) frame_.clear();  // an empty frame (the host's leading delimiter)
      continue;
    }
    DeviceFrame frame;
    frame.wire = frame_;
    frame.at = clock_->now();
    frame_.clear();
    if (status == DecodeStatus::error) {
      frame.damaged = true;
    } else {
      frame.payload.assign(reinterpret_cast<const char*>(decoder_.frame().data()), decoder_.frame().size());
      const int length = static_cast<int>(frame.payload.size());
      frame.decoded = integrity_ == Integrity::crc16 ? frame.in.ParseFromArray(frame.payload.data(), length)
                                                     : frame.compat.ParseFromArray(frame.payload.data(), length);
      frame.repeat = ++seen_[frame.payload];
    }
    deliver(frame);
  }
}

FakeDevice::Script standard_device(std::uint32_t first_session, std::function<bool(const DeviceFrame&)> ignore) {
  auto session = std::make_shared<std::atomic<std::uint32_t>>(first_session);
  return [session, ignore = std::move(ignore)](const DeviceFrame& frame, FakeDevice& device) {
    if (!frame.decoded) return;
    if (ignore && ignore(frame)) return;
    device.send(FakeDevice::ack(frame.in.messageid()));
    if (frame.in.has_reset()) device.send(FakeDevice::reset_event((*session)++));
  };
}

std::string hex(const std::string& bytes) {
  std::string text;
  char digits[4];
  for (const char c : bytes) {
    std::snprintf(digits, sizeof digits, "%02x", static_cast<unsigned>(static_cast<unsigned char>(c)));
    if (!text.empty()) text.push_back(' ');
    text += digits;
  }
  return text;
}

std::string unhex(const std::string& text) {
  std::string bytes;
  unsigned value = 0;
  int digits = 0;
  for (const char c : text) {
    int nibble = -1;
    if (c >= '0' && c <= '9') nibble = c - '0';
    if (c >= 'a' && c <= 'f') nibble = c - 'a' + 10;
    if (c >= 'A' && c <= 'F') nibble = c - 'A' + 10;
    if (nibble < 0) continue;
    value = value * 16 + static_cast<unsigned>(nibble);
    if (++digits == 2) {
      bytes.push_back(static_cast<char>(value));
      value = 0;
      digits = 0;
    }
  }
  return bytes;
}

}  // namespace tether::proxy::testing
