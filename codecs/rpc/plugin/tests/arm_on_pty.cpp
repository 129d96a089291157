// The arm device on a pty: see arm_on_pty.hpp.
#include "arm_on_pty.hpp"

#include <boost/asio/buffer.hpp>

#include <chrono>

#include "tether/transports/transport_error.hpp"

namespace tether::rpc::testing {

ArmOnPty::ArmOnPty(std::uint64_t schema_hash, std::uint32_t session)
    : pty_(transports::PtyStream::open(io_.executor())),
      device_(schema_hash, [this](std::string frame) { pty_->write(boost::asio::buffer(frame.data(), frame.size())); }) {
  device_.boot(session, now());
  thread_ = std::thread([this] { serve(); });
}

ArmOnPty::~ArmOnPty() {
  stop_ = true;
  thread_.join();
  pty_->close();
}

Millis ArmOnPty::now() const {
  return static_cast<Millis>(
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start_).count());
}

void ArmOnPty::serve() {
  while (!stop_) {
    std::uint8_t buffer[256];
    boost::system::error_code error;
    // Short reads: the device's streams and hellos run from its poll between them.
    const std::size_t size = pty_->read_some(boost::asio::buffer(buffer), std::chrono::milliseconds(5), error);
    if (error && error != transports::TransportError::timed_out) {
      // No host on the slave yet, or it just closed it: the board keeps running.
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::lock_guard lock(mutex_);
    if (size > 0) device_.feed(buffer, size, now());
    device_.poll(now());
  }
}

}  // namespace tether::rpc::testing
