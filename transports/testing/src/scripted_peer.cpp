// ScriptedPeer: the stream-serving part of the codec fake devices.
#include "tether/transports/testing/scripted_peer.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>

namespace tether::transports::testing {

namespace asio = boost::asio;

ScriptedPeer::ScriptedPeer(std::shared_ptr<ByteStream> end)
    : end_(std::move(end)),
      strand_(asio::make_strand(end_->get_executor())),
      buffer_(std::make_shared<std::array<std::uint8_t, 512>>()) {}

ScriptedPeer::~ScriptedPeer() {
  error_code ignored;
  end_->close(ignored);
}

void ScriptedPeer::start() {
  asio::post(strand_, [self = shared_from_this()] { self->read(); });
}

void ScriptedPeer::send(std::string bytes) {
  auto frame = std::make_shared<std::string>(std::move(bytes));
  asio::post(strand_, [self = shared_from_this(), frame] {
    self->writes_.push_back(frame);
    if (!self->writing_) self->write_next();
  });
}

void ScriptedPeer::send_after(std::chrono::milliseconds delay, std::string bytes) {
  asio::post(strand_, [self = shared_from_this(), delay, bytes = std::move(bytes)]() mutable {
    auto timer = std::make_shared<asio::steady_timer>(self->strand_, delay);
    self->timers_.push_back(timer);
    timer->async_wait([weak = self->weak_from_this(), timer, bytes = std::move(bytes)](error_code error) mutable {
      const auto peer = weak.lock();
      if (error || !peer) return;
      peer->send(std::move(bytes));
    });
  });
}

void ScriptedPeer::close() {
  asio::post(strand_, [self = shared_from_this()] {
    for (auto& timer : self->timers_) timer->cancel();
    self->timers_.clear();
  });
  error_code ignored;
  end_->close(ignored);
}

std::string ScriptedPeer::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}

void ScriptedPeer::record(const std::function<void()>& update) const {
  {
    std::lock_guard lock(mutex_);
    update();
  }
  changed_.notify_all();
}

void ScriptedPeer::inspect(const std::function<void()>& read) const {
  std::lock_guard lock(mutex_);
  read();
}

bool ScriptedPeer::wait_until(const std::function<bool()>& ready, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, ready);
}

void ScriptedPeer::read() {
  auto buffer = buffer_;
  auto on_read = [weak = weak_from_this(), buffer](error_code error, std::size_t size) {
    const auto self = weak.lock();
    if (!self || error) return;
    {
      std::lock_guard lock(self->mutex_);
      self->received_.append(reinterpret_cast<const char*>(buffer->data()), size);
    }
    self->on_bytes(buffer->data(), size);
    self->read();
  };
  end_->async_read_some(asio::buffer(*buffer), asio::bind_executor(strand_, std::move(on_read)));
}

void ScriptedPeer::write_next() {
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

}  // namespace tether::transports::testing
