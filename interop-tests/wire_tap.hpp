// A wire between a host-side stream and a device stream that lets a test see, change or drop the bytes
// in each direction as they pass (deterministic faults on chosen frames, where FaultModel's are random).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <utility>
#include <vector>

#include "tether/transports/byte_stream.hpp"

namespace tether::testing {

/// Copies bytes host -> device and device -> host on two threads, through `tap`, until destroyed.
class WireTap {
 public:
  /// Called for every byte, on the thread of its direction: appends to `out` what goes on (the byte, a
  /// changed byte, nothing, or a whole frame held back until its last byte).
  using Tap = std::function<void(bool from_device, std::uint8_t byte, std::vector<std::uint8_t>& out)>;

  WireTap(std::shared_ptr<transports::ByteStream> host_side, std::shared_ptr<transports::ByteStream> device, Tap tap)
      : host_side_(std::move(host_side)), device_(std::move(device)), tap_(std::move(tap)) {
    upstream_ = std::thread([this] { pump(*host_side_, *device_, false); });
    downstream_ = std::thread([this] { pump(*device_, *host_side_, true); });
  }
  ~WireTap() {
    running_ = false;
    upstream_.join();
    downstream_.join();
  }
  WireTap(const WireTap&) = delete;
  WireTap& operator=(const WireTap&) = delete;

 private:
  void pump(transports::ByteStream& from, transports::ByteStream& to, bool from_device) {
    std::vector<std::uint8_t> buffer(256);
    std::vector<std::uint8_t> out;
    while (running_) {
      boost::system::error_code error;
      const std::size_t got = from.read_some(boost::asio::buffer(buffer), std::chrono::milliseconds(20), error);
      out.clear();
      for (std::size_t i = 0; i < got; ++i) tap_(from_device, buffer[i], out);
      if (!out.empty()) to.write(boost::asio::buffer(out), error);
    }
  }

  std::shared_ptr<transports::ByteStream> host_side_;
  std::shared_ptr<transports::ByteStream> device_;
  Tap tap_;
  std::atomic<bool> running_{true};
  std::thread upstream_;
  std::thread downstream_;
};

}  // namespace tether::testing
