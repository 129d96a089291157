#include "fake_device.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>

#include <array>

#include "tether/romi/encoder.hpp"

namespace tether::romi::testing {

namespace asio = boost::asio;
using boost::system::error_code;

std::shared_ptr<FakeDevice> FakeDevice::start(std::shared_ptr<transports::ByteStream> end) {
  auto device = std::make_shared<FakeDevice>(std::move(end), 0);
  asio::post(device->strand_, [device] { device->read(); });
  return device;
}

FakeDevice::FakeDevice(std::shared_ptr<transports::ByteStream> end, int)
    : end_(std::move(end)),
      strand_(asio::make_strand(end_->get_executor())),
      buffer_(std::make_shared<std::array<std::uint8_t, 512>>()) {}

FakeDevice::~FakeDevice() {
  error_code ignored;
  end_->close(ignored);
}

void FakeDevice::on_request(Script script) {
  std::lock_guard lock(mutex_);
  script_ = std::move(script);
}

void FakeDevice::send(std::string bytes) {
  auto frame = std::make_shared<std::string>(std::move(bytes));
  asio::post(strand_, [self = shared_from_this(), frame] {
    self->writes_.push_back(frame);
    if (!self->writing_) self->write_next();
  });
}

void FakeDevice::send_after(std::chrono::milliseconds delay, std::string bytes) {
  asio::post(strand_, [self = shared_from_this(), delay, bytes = std::move(bytes)]() mutable {
    auto timer = std::make_shared<asio::steady_timer>(self->strand_, delay);
    self->timers_.push_back(timer);
    timer->async_wait([weak = self->weak_from_this(), timer, bytes = std::move(bytes)](error_code error) mutable {
      const auto device = weak.lock();
      if (error || !device) return;
      device->send(std::move(bytes));
    });
  });
}

void FakeDevice::close() {
  asio::post(strand_, [self = shared_from_this()] {
    for (auto& timer : self->timers_) timer->cancel();
    self->timers_.clear();
  });
  error_code ignored;
  end_->close(ignored);
}

std::vector<DeviceRequest> FakeDevice::requests() const {
  std::lock_guard lock(mutex_);
  return requests_;
}

std::string FakeDevice::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}

bool FakeDevice::wait_for_requests(std::size_t count, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return requests_.size() >= count; });
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

void FakeDevice::read() {
  auto buffer = buffer_;
  auto on_read = [weak = weak_from_this(), buffer](error_code error, std::size_t size) {
    const auto self = weak.lock();
    if (!self || error) return;
    self->on_bytes(buffer->data(), size);
    self->read();
  };
  end_->async_read_some(asio::buffer(*buffer), asio::bind_executor(strand_, std::move(on_read)));
}

void FakeDevice::on_bytes(const std::uint8_t* data, std::size_t size) {
  {
    std::lock_guard lock(mutex_);
    received_.append(reinterpret_cast<const char*>(data), size);
  }
  for (std::size_t i = 0; i < size; ++i) {
    const std::uint8_t byte = data[i];
    if (byte == '#') frame_.clear();
    frame_.push_back(static_cast<char>(byte));
    const EnvelopeEvent event = decoder_.feed(byte);
    if (event.kind == EnvelopeEvent::Kind::none) continue;
    DeviceRequest request;
    request.frame = frame_;
    request.manual = event.manual;
    request.id = event.id;
    request.opcode = event.opcode;
    request.error = event.kind == EnvelopeEvent::Kind::error ? event.error : ErrorCode::no_error;
    request.payload.assign(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
    request.repeat = ++seen_[frame_];
    frame_.clear();
    Script script;
    {
      std::lock_guard lock(mutex_);
      requests_.push_back(request);
      script = script_;
    }
    changed_.notify_all();
    if (script) script(request, *this);
  }
}

void FakeDevice::write_next() {
  if (writes_.empty()) {
    writing_ = false;
    return;
  }
  writing_ = true;
  auto frame = writes_.front();
  writes_.pop_front();
  asio::async_write(*end_, asio::buffer(*frame),
                    asio::bind_executor(strand_, [self = shared_from_this(), frame](error_code error, std::size_t) {
                      if (error) {
                        self->writes_.clear();
                        self->writing_ = false;
                        return;
                      }
                      self->write_next();
                    }));
}

}  // namespace tether::romi::testing
