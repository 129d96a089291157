// The user's path of the rpc codec on an Arduino: `tether generate examples/rpc/arm.proto` wrote the ArmRpc
// library, arduino-builder built examples/rpc/ArmSketch against it (the ctest fixtures before this test:
// codecs/rpc/arduino/CMakeLists.txt), and here the sketch runs on the virtual Uno, driven by the host's rpc
// client: the hello's schema hash, calls with their replies and the device's errors, a stream. The client's
// deadlines run on the board's simulated clock, so a loaded machine changes nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "../../interop/arm_board.hpp"
#include "arm.pb.h"
#include "tether/rpc/client.hpp"
#include "tether/testing/eventually.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno_clock.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::rpc {
namespace {

using namespace std::chrono_literals;
using transports::IoThread;
using transports::Pacing;
using transports::VirtualUnoOptions;
using transports::VirtualUnoStream;
using uno_testing::as;
using uno_testing::Received;
using uno_testing::joint_request;
using uno_testing::let_board_run;
using uno_testing::on_board_time;
using uno_testing::wait_for;

const std::string kArmSchema = TETHER_RPC_EXAMPLE_SCHEMA;

VirtualUnoOptions board() { return uno_testing::arm_board(TETHER_RPC_SKETCH_ELF); }

TEST(RpcArduinoSketch, TheHelloCarriesTheSchemasHash) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  const SessionStatus session = client.session();
  EXPECT_TRUE(session.established);
  ASSERT_TRUE(session.device_hash.has_value());
  EXPECT_EQ(*session.device_hash, Schema::load(kArmSchema).hash()) << format_hash(*session.device_hash);
  ASSERT_TRUE(session.session_id.has_value());
  EXPECT_NE(*session.session_id, 0u);
  client.close();
}

TEST(RpcArduinoSketch, CallsAnswerWithTheSketchsRepliesAndErrors) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();

  EXPECT_EQ(as<arm::JointReply>(*client.call("MoveJoint", joint_request(2, -4500)).reply).reached_cdeg(), -4500);
  EXPECT_EQ(client.call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 12345})"), R"({"reachedCdeg":12345})");

  // The handler's own error: its code and text reach the caller; nothing ran.
  error_code error;
  CallResult result = client.call("MoveJoint", joint_request(7, 0), error);
  EXPECT_EQ(error, RpcError::device_error) << error.message();
  EXPECT_EQ(result.device_error.code, 1);
  EXPECT_EQ(result.device_error.text, "no joint");
  arm::ModeRequest hold;
  hold.set_mode(arm::MODE_HOLD);
  EXPECT_EQ(as<arm::ModeReply>(*client.call("SetMode", hold).reply).previous(), arm::MODE_IDLE);
  result = client.call("MoveJoint", joint_request(0, 100), error);
  EXPECT_EQ(result.device_error.code, 3);
  EXPECT_EQ(result.device_error.text, "on hold");

  const auto description = as<arm::Description>(*client.call("Describe", arm::DescribeRequest()).reply);
  EXPECT_EQ(description.name(), "tether-arm");
  EXPECT_EQ(description.joints(), 4u);
  EXPECT_EQ(description.min_cdeg(), -18000);
  EXPECT_EQ(description.max_cdeg(), 18000);
  EXPECT_EQ(description.moves(), 2u);
  EXPECT_EQ(client.counters().device_errors, 2u);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

TEST(RpcArduinoSketch, WatchStreamsTheStateAtItsPeriodUntilClosed) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  auto& uno = stream->board();
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  client.call("MoveJoint", joint_request(3, 9000));
  Received received;
  Stream watch = client.open_stream("Watch", arm::StateRequest(), 20ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 10; }));
  watch.close();
  std::size_t at_close = 0;
  {
    std::lock_guard lock(received.mutex);
    at_close = received.seqs.size();
    for (std::size_t i = 0; i < received.seqs.size(); ++i) EXPECT_EQ(received.seqs[i], i) << "message " << i;
    const arm::State& state = received.states.front();
    ASSERT_EQ(state.angles_cdeg_size(), 4);
    EXPECT_EQ(state.angles_cdeg(3), 9000);
    EXPECT_EQ(state.mode(), arm::MODE_IDLE);
    // The sketch's millis() in the messages: one period apart (its loop polls far more often).
    for (std::size_t i = 2; i < received.states.size(); ++i) {
      const std::uint32_t step = received.states[i].millis() - received.states[i - 1].millis();
      EXPECT_GE(step, 19u) << "message " << i;
      EXPECT_LE(step, 21u) << "message " << i;
    }
    EXPECT_TRUE(received.ends.empty());
  }
  let_board_run(uno, 200ms);
  EXPECT_LE(received.count(), at_close + 1);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

// The Arduino core (its Serial's 64-byte rings, its own state) beside the runtime's tables: the sketch's
// deepest stack over every method, an error and a stream must still leave SRAM unused.
TEST(RpcArduinoSketch, PeakStackOverEveryMethodLeavesRamUnused) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Options options = on_board_time(stream);
  options.timing.ping_period = 0;  // the device idle across the paint
  Client client(stream, Schema::load(kArmSchema), options);
  uno_testing::expect_ram_unused_after_everything(client, stream->board(), "ArmSketch");
  client.close();
}

}  // namespace
}  // namespace tether::rpc
