#include "fake_device.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>

#include <cstdio>

namespace tether::proxy::testing {

namespace asio = boost::asio;
using boost::system::error_code;

std::shared_ptr<FakeDevice> FakeDevice::start(std::shared_ptr<transports::ByteStream> end, Integrity integrity,
                                              Script script) {
  auto device = std::make_shared<FakeDevice>(std::move(end), integrity, 0);
  device->on_frame(std::move(script));
  asio::post(device->strand_, [device] { device->read(); });
  return device;
}

FakeDevice::FakeDevice(std::shared_ptr<transports::ByteStream> end, Integrity integrity, int)
    : end_(std::move(end)),
      integrity_(integrity),
      strand_(asio::make_strand(end_->get_executor())),
      decoder_(integrity, counters_),
      buffer_(std::make_shared<std::array<std::uint8_t, 512>>()) {}

FakeDevice::~FakeDevice() {
  error_code ignored;
  end_->close(ignored);
}

void FakeDevice::on_frame(Script script) {
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

std::vector<DeviceFrame> FakeDevice::frames() const {
  std::lock_guard lock(mutex_);
  return frames_;
}

std::string FakeDevice::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}

bool FakeDevice::wait_for(const std::function<bool(const std::vector<DeviceFrame>&)>& predicate,
                          std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return predicate(frames_); });
}

std::string FakeDevice::frame_bytes(const std::string& payload, Integrity integrity) {
  std::vector<std::uint8_t> out(max_frame_size(payload.size()));
  const auto size = encode_frame(ByteView::from_chars(payload.data(), payload.size()), integrity, false,
                                 MutableByteView(out.data(), out.size()));
  return std::string(reinterpret_cast<const char*>(out.data()), size.ok() ? size.value() : 0);
}

std::string FakeDevice::frame(const ArduinoOut& out) { return frame_bytes(out.SerializeAsString(), Integrity::crc16); }

std::string FakeDevice::ack(std::uint32_t message_id) {
  ArduinoOut out;
  out.mutable_ack()->set_messageid(message_id);
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
    frame_.push_back(static_cast<char>(byte));
    const FrameEvent event = decoder_.feed(byte);
    if (event.kind == FrameEvent::Kind::none) {
      if (byte == 0x00) frame_.clear();  // an empty frame (the host's leading delimiter)
      continue;
    }
    DeviceFrame frame;
    frame.wire = frame_;
    frame.at = std::chrono::steady_clock::now();
    frame_.clear();
    if (event.kind == FrameEvent::Kind::error) {
      frame.damaged = true;
    } else {
      frame.payload.assign(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
      const int length = static_cast<int>(frame.payload.size());
      frame.decoded = integrity_ == Integrity::crc16 ? frame.in.ParseFromArray(frame.payload.data(), length)
                                                     : frame.compat.ParseFromArray(frame.payload.data(), length);
      frame.repeat = ++seen_[frame.payload];
    }
    Script script;
    {
      std::lock_guard lock(mutex_);
      frames_.push_back(frame);
      script = script_;
    }
    changed_.notify_all();
    if (script) script(frame, *this);
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
