// The arm device (arm_device.hpp) on the device end of an in-memory link, for the client tests: host bytes
// into the device, its frames back, on a manual clock; faults on request (dropped answers or requests, a
// deaf device).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>

#include "arm_device.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/testing/scripted_peer.hpp"

namespace tether::rpc::testing {

// The device end of the link: host bytes into the arm device, its frames back; faults on request.
class ArmPeer : public transports::testing::ScriptedPeer {
 public:
  ArmPeer(std::shared_ptr<transports::ByteStream> end, std::uint64_t hash,
          std::shared_ptr<client::testing::ManualClock> clock)
      : ScriptedPeer(std::move(end)), clock_(std::move(clock)), device_(hash, [this](std::string frame) { out(std::move(frame)); }) {}

  static std::shared_ptr<ArmPeer> start(std::shared_ptr<transports::ByteStream> end, std::uint64_t hash,
                                        std::shared_ptr<client::testing::ManualClock> clock) {
    auto peer = std::make_shared<ArmPeer>(std::move(end), hash, std::move(clock));
    peer->ScriptedPeer::start();
    return peer;
  }

  // Everything below: any thread, under the peer's lock.
  void boot(std::uint32_t session) {
    record([&] { device_.boot(session, clock_->now()); });
  }
  void poll() {
    record([&] { device_.poll(clock_->now()); });
  }
  void drop_answers(int count) {
    record([&] { drop_answers_ = count; });
  }
  void drop_requests(int count) {
    record([&] { drop_requests_ = count; });
  }
  void deaf(bool deaf) {
    record([&] { deaf_ = deaf; });
  }
  template <typename Read>
  auto read(Read&& read_device) const {
    std::invoke_result_t<Read, const ArmDevice&> value{};
    inspect([&] { value = read_device(device_); });
    return value;
  }
  void with_device(const std::function<void(ArmDevice&)>& change) {
    record([&] { change(device_); });
  }
  /// The device's MoveJoint runs, its open streams; MoveJoint answering an error from now on.
  int moves() const {
    return read([](const ArmDevice& device) { return device.moves(); });
  }
  int open_streams() const {
    return read([](const ArmDevice& device) { return device.open_streams(); });
  }
  void fail_moves(std::uint16_t code, const std::string& text) {
    with_device([&](ArmDevice& device) { device.fail_moves(code, text); });
  }

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    record([&] {
      if (deaf_) return;
      // Whole frames only are dropped: the client writes each frame (leading 0x00 included) at once.
      if (drop_requests_ > 0 && size > 0 && data[size - 1] == 0) {
        --drop_requests_;
        return;
      }
      device_.feed(data, size, clock_->now());
    });
  }
  void out(std::string frame) {  // under the lock (called from the device)
    if (drop_answers_ > 0) {
      --drop_answers_;
      return;
    }
    send(std::move(frame));
  }

  std::shared_ptr<client::testing::ManualClock> clock_;
  ArmDevice device_;
  int drop_answers_ = 0;
  int drop_requests_ = 0;
  bool deaf_ = false;
};

}  // namespace tether::rpc::testing
