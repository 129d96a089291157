// The tests' arm device (codecs/rpc/host/tests/arm_device.hpp: the generated service of the arm schema on
// the real device runtime, built for the host) served on the master side of a pty by a thread of its own,
// on the steady clock: a configuration's serial transport or `tether --port` opens the slave like a board's
// serial port. Until the bare-metal rpc image can run on a virtual Uno, this is the device the plugin's and
// the command's tests talk to.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "arm_device.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"

namespace tether::rpc::testing {

class ArmOnPty {
 public:
  /// Boots the device (its hello carrying `schema_hash`) and serves it until destroyed.
  explicit ArmOnPty(std::uint64_t schema_hash, std::uint32_t session = 0x5E55);
  ~ArmOnPty();
  ArmOnPty(const ArmOnPty&) = delete;
  ArmOnPty& operator=(const ArmOnPty&) = delete;

  /// The port to open (the pty's slave).
  const std::string& path() const { return pty_->slave_path(); }
  /// The device, for the test's thread (its serving thread is paused while `change` runs).
  template <typename Change>
  auto with_device(Change&& change) {
    std::lock_guard lock(mutex_);
    return change(device_);
  }

 private:
  void serve();
  Millis now() const;

  transports::IoThread io_;
  std::shared_ptr<transports::PtyStream> pty_;
  std::mutex mutex_;
  ArmDevice device_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tether::rpc::testing
