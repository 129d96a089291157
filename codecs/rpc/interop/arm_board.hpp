// What the tests of an rpc device on the virtual Uno share (the example's image: interop/; the Arduino
// sketch: arduino/tests/): the board, the client's clock on its simulated time, waits, and the example
// schema's messages.
#pragma once

#include <google/protobuf/message.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "../../../interop-tests/stack_paint.hpp"
#include "arm.pb.h"
#include "tether/rpc/client.hpp"
#include "tether/testing/eventually.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/virtual_uno_clock.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::rpc::uno_testing {

/// A board running `firmware` in real time (the test's random seed).
inline transports::VirtualUnoOptions arm_board(const std::string& firmware) {
  transports::VirtualUnoOptions options;
  options.firmware = firmware;
  options.pacing = transports::Pacing::real_time;
  options.seed = tether::testing::random_seed();
  return options;
}

/// Deadlines (acks, hellos, pings) on the board's simulated time, the clock of the firmware's own rules.
inline Options on_board_time(const std::shared_ptr<transports::VirtualUnoStream>& stream) {
  Options options;
  options.clock = transports::VirtualUnoClock::create(stream);
  return options;
}

/// Waits (wall time) until `predicate` holds; the limit only stops a hang.
template <typename Predicate>
bool wait_for(Predicate predicate, std::chrono::milliseconds limit = std::chrono::seconds(120)) {
  return tether::testing::eventually(predicate, limit);
}

/// Waits until the board's simulated time has moved `span` on.
inline void let_board_run(transports::VirtualUno& uno, std::chrono::milliseconds span) {
  const auto from = uno.simulated_time();
  ASSERT_TRUE(wait_for([&] { return uno.simulated_time() - from >= span; }));
}

/// A dynamic message (the client's schema pool) as the generated class of the same type.
template <typename Typed>
Typed as(const google::protobuf::Message& message) {
  Typed typed;
  EXPECT_TRUE(typed.ParseFromString(message.SerializeAsString())) << message.GetTypeName();
  return typed;
}

/// MoveJoint's request.
inline arm::JointRequest joint_request(std::uint32_t joint, std::int32_t angle) {
  arm::JointRequest request;
  request.set_joint(joint);
  request.set_angle_cdeg(angle);
  return request;
}

/// What a stream handler received, for the test's thread.
struct Received {
  std::mutex mutex;
  std::vector<std::uint32_t> seqs;
  std::vector<arm::State> states;
  std::vector<error_code> ends;
  std::vector<std::string> end_texts;  // the device's text of each end
  StreamHandler handler() {
    return [this](const error_code& error, const StreamMessage& message) {
      std::lock_guard lock(mutex);
      if (error) {
        ends.push_back(error);
        end_texts.push_back(message.device_error.text);
        return;
      }
      seqs.push_back(message.seq);
      states.push_back(as<arm::State>(*message.message));
    };
  }
  std::size_t count() {
    std::lock_guard lock(mutex);
    return seqs.size();
  }
};

/// Every unary method of the example, three times, with a device error each time (the peak-stack tests'
/// exercise before their stream).
inline void call_every_method(Client& client) {
  error_code error;
  for (int i = 0; i < 3; ++i) {
    client.call("MoveJoint", joint_request(1, -17999 + i), error);
    EXPECT_FALSE(error) << error.message();
    client.call("MoveJoint", joint_request(9, 0), error);
    EXPECT_EQ(error, RpcError::device_error);
    arm::ModeRequest mode;
    mode.set_mode(arm::MODE_ACTIVE);
    mode.mutable_range()->set_min_cdeg(-18000);
    mode.mutable_range()->set_max_cdeg(18000);
    client.call("SetMode", mode, error);
    EXPECT_FALSE(error) << error.message();
    const CallResult described = client.call("Describe", arm::DescribeRequest(), error);
    EXPECT_FALSE(error) << error.message() << " " << described.device_error.text;
  }
}

/// The peak-stack tests' run and verdict, on a board whose client was made with `timing.ping_period = 0`
/// (the paint reads the stack pointer and writes the SRAM below it at two quantum boundaries, so the device
/// must be idle across both: a frame handled between them would be painted over). With the free SRAM
/// painted: every method, an error, a 100 Hz stream with a call between its messages and the device's own
/// hello; then prints `[ figures ] NAME: static RAM, peak stack, RAM never used` and expects at least 64 B
/// never used.
inline void expect_ram_unused_after_everything(Client& client, transports::VirtualUno& uno, const char* name) {
  using namespace std::chrono_literals;
  client.wait_ready();
  let_board_run(uno, 20ms);
  testing::paint_free_sram(uno);
  call_every_method(client);
  error_code error;
  Received received;
  Stream watch = client.open_stream("Watch", arm::StateRequest(), 10ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 20; }))
      << received.count() << " messages, ended: " << (received.end_texts.empty() ? "no" : received.end_texts[0]);
  client.call("MoveJoint", joint_request(2, 4500), error);  // a call between stream messages
  EXPECT_FALSE(error) << error.message();
  watch.close();
  let_board_run(uno, 5100ms);  // a DeviceHello of its own
  const std::size_t stack = testing::peak_stack(uno);
  const std::size_t static_ram = testing::heap_start(uno) - transports::atmega328p::kSramStart;
  const std::size_t never_used = testing::never_used_sram(uno);
  std::printf("[ figures ] %s: static RAM %zu B, peak stack %zu B, %zu B of RAM never used\n", name, static_ram, stack,
              never_used);
  EXPECT_GE(never_used, 64u) << "static data " << static_ram << " B + peak stack " << stack << " B";
}

}  // namespace tether::rpc::uno_testing
