#include "fake_device.hpp"

#include <vector>

#include "tether/romi/encoder.hpp"

namespace tether::romi::testing {

std::shared_ptr<FakeDevice> FakeDevice::start(std::shared_ptr<transports::ByteStream> end) {
  auto device = std::make_shared<FakeDevice>(std::move(end), 0);
  device->ScriptedPeer::start();
  return device;
}

FakeDevice::FakeDevice(std::shared_ptr<transports::ByteStream> end, int) : ScriptedDevice(std::move(end)) {}

bool FakeDevice::wait_for_requests(std::size_t count, std::chrono::milliseconds timeout) const {
  return wait_for_records([count](const std::vector<DeviceRequest>& requests) { return requests.size() >= count; },
                          timeout);
}

std::string FakeDevice::response(char opcode, std::string_view body, std::uint8_t id) {
  std::vector<std::uint8_t> buffer(body.size() + 16);
  const auto size = encode_response(opcode, ByteView::from_chars(body.data(), body.size()), id,
                                    MutableByteView(buffer.data(), buffer.size()));
  return std::string(reinterpret_cast<const char*>(buffer.data()), size.ok() ? size.value() : 0);
}

std::string FakeDevice::log(std::string_view text) {
  std::vector<std::uint8_t> buffer(text.size() + 16);
  const auto size =
      encode_log(ByteView::from_chars(text.data(), text.size()), MutableByteView(buffer.data(), buffer.size()));
  return std::string(reinterpret_cast<const char*>(buffer.data()), size.ok() ? size.value() : 0);
}

std::string FakeDevice::corrupt_crc(std::string frame) {
  // The CRC is the two characters before "\r\n"; change the last one to another hex digit.
  char& digit = frame[frame.size() - 3];
  digit = digit == '0' ? '1' : '0';
  return frame;
}

void FakeDevice::on_bytes(const std::uint8_t* data, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint8_t byte = data[i];
    if (byte == '#') frame_.clear();
    frame_.push_back(static_cast<char>(byte));
    const DecodeStatus status = decoder_.feed(byte);
    if (status == DecodeStatus::more) continue;
    const Frame& event = decoder_.frame();
    DeviceRequest request;
    request.frame = frame_;
    request.manual = event.manual;
    request.id = event.id;
    request.opcode = event.opcode;
    request.error = status == DecodeStatus::error ? decoder_.error() : Error::no_error;
    request.payload.assign(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
    request.repeat = ++seen_[frame_];
    frame_.clear();
    deliver(request);
  }
}

}  // namespace tether::romi::testing
