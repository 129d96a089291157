// The rpc codec end to end: the host's rpc::Client against the example's bare-metal image
// (build/firmware/rpc-example.elf, examples/rpc/arm.proto) on the virtual Uno. The client's deadlines run
// on the board's simulated clock, so a loaded machine (a board slower than real time) changes nothing.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "arm_board.hpp"
#include "arm.pb.h"
#include "tether/client/testing/event_log.hpp"
#include "tether/core/execution_witness.hpp"
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
using EventLog = client::testing::EventLog<Event>;
using uno_testing::as;
using uno_testing::Received;
using uno_testing::joint_request;
using uno_testing::let_board_run;
using uno_testing::on_board_time;
using uno_testing::wait_for;

const std::string kArmSchema = TETHER_RPC_EXAMPLE_SCHEMA;
const std::string kOtherSchema = TETHER_RPC_INTEROP_DIR "/other_arm.proto";

VirtualUnoOptions board() { return uno_testing::arm_board(std::string(TETHER_FIRMWARE_DIR) + "/rpc-example.elf"); }

template <typename Typed>
Typed from_json(const std::string& json) {
  Typed typed;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &typed);
  EXPECT_TRUE(status.ok()) << json << ": " << status.ToString();
  return typed;
}

// The image's execution witness (tether/core/execution_witness.hpp): the MoveJoint calls that ran, by key
// witness_key(joint, uint16_t(angle)), read from the board's SRAM.
class MoveWitness {
 public:
  explicit MoveWitness(transports::VirtualUno& uno) : uno_(uno) {
    const auto symbol = uno.symbol("tether_execution_witness");
    EXPECT_TRUE(symbol && symbol->space == transports::FirmwareSymbol::Space::data &&
                symbol->size == kWitnessRecordSize);
    if (symbol) address_ = static_cast<std::uint16_t>(symbol->address);
  }
  // The new executions since the last read (fewer than kWitnessLogSize between reads, or some are lost:
  // counted in `unobserved`).
  void read() {
    const std::vector<std::uint8_t> record = uno_.read_memory(address_, kWitnessRecordSize);
    const std::uint8_t executed = record[kWitnessExecutedOffset];
    const auto fresh = static_cast<std::uint8_t>(executed - seen_);
    const std::uint8_t kept = std::min<std::uint8_t>(fresh, kWitnessLogSize);
    unobserved += fresh - kept;
    for (std::uint8_t n = 0; n < kept; ++n) {
      const auto number = static_cast<std::uint8_t>(executed - kept + n);
      const std::size_t slot = kWitnessLogOffset + 4u * (number % kWitnessLogSize);
      const std::uint32_t key = static_cast<std::uint32_t>(record[slot]) | static_cast<std::uint32_t>(record[slot + 1]) << 8 |
                                static_cast<std::uint32_t>(record[slot + 2]) << 16 |
                                static_cast<std::uint32_t>(record[slot + 3]) << 24;
      ++runs[key];
    }
    seen_ = executed;
  }
  std::map<std::uint32_t, int> runs;  // executions by key
  unsigned unobserved = 0;

 private:
  transports::VirtualUno& uno_;
  std::uint16_t address_ = 0;
  std::uint8_t seen_ = 0;
};

std::uint32_t move_key(std::uint32_t joint, std::int32_t angle) {
  return witness_key(static_cast<std::uint16_t>(joint), static_cast<std::uint16_t>(angle));
}

TEST(RpcInterop, TheDeviceHelloCarriesTheSchemaHash) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  EventLog log;
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream), log.handler());
  client.wait_ready();
  const SessionStatus session = client.session();
  EXPECT_TRUE(session.established);
  ASSERT_TRUE(session.device_hash.has_value());
  EXPECT_EQ(*session.device_hash, Schema::load(kArmSchema).hash()) << format_hash(*session.device_hash);
  ASSERT_TRUE(session.session_id.has_value());
  EXPECT_NE(*session.session_id, 0u);
  ASSERT_EQ(log.of<events::SessionEstablished>().size(), 1u);
  EXPECT_TRUE(log.of<events::SessionEstablished>()[0].first);
  EXPECT_TRUE(log.of<events::SchemaMismatch>().empty());
  client.close();
}

TEST(RpcInterop, EveryMethodAnswersWithItsFieldKindsTypedAndAsJson) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();

  // Typed: uint32 and a negative int32 in, an int32 out.
  CallResult moved = client.call("MoveJoint", joint_request(2, -4500));
  EXPECT_EQ(as<arm::JointReply>(*moved.reply).reached_cdeg(), -4500);
  // JSON (protobuf's mapping, lowerCamelCase names).
  EXPECT_EQ(from_json<arm::JointReply>(client.call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 12345})")).reached_cdeg(),
            12345);

  // An enum, typed and by name in JSON.
  arm::ModeRequest mode;
  mode.set_mode(arm::MODE_ACTIVE);
  EXPECT_EQ(as<arm::ModeReply>(*client.call("SetMode", mode).reply).previous(), arm::MODE_IDLE);
  EXPECT_EQ(from_json<arm::ModeReply>(client.call_json("SetMode", R"({"mode": "MODE_HOLD"})")).previous(),
            arm::MODE_ACTIVE);
  EXPECT_EQ(from_json<arm::ModeReply>(client.call_json("SetMode", R"({"mode": 1})")).previous(), arm::MODE_HOLD);

  // A nested message in the request, typed and as JSON.
  mode.set_mode(arm::MODE_ACTIVE);
  mode.mutable_range()->set_min_cdeg(-9000);
  mode.mutable_range()->set_max_cdeg(9000);
  EXPECT_EQ(as<arm::ModeReply>(*client.call("SetMode", mode).reply).previous(), arm::MODE_ACTIVE);
  error_code error;
  const CallResult outside = client.call("MoveJoint", joint_request(0, 9001), error);
  EXPECT_EQ(error, RpcError::device_error);
  EXPECT_EQ(outside.device_error.code, 2);

  // A string, a negative int32 and counters, typed and as JSON.
  const auto description = as<arm::Description>(*client.call("Describe", arm::DescribeRequest()).reply);
  EXPECT_EQ(description.name(), "tether-arm");
  EXPECT_EQ(description.joints(), 4u);
  EXPECT_EQ(description.min_cdeg(), -9000);
  EXPECT_EQ(description.max_cdeg(), 9000);
  EXPECT_EQ(description.moves(), 2u);
  EXPECT_EQ(from_json<arm::ModeReply>(
                client.call_json("SetMode", R"({"mode": "MODE_ACTIVE", "range": {"minCdeg": -18000, "maxCdeg": 18000}})"))
                .previous(),
            arm::MODE_ACTIVE);
  const std::string json = client.call_json("Describe", "{}");
  EXPECT_NE(json.find("\"name\":\"tether-arm\""), std::string::npos) << json;
  const auto from_text = from_json<arm::Description>(json);
  EXPECT_EQ(from_text.min_cdeg(), -18000);
  EXPECT_EQ(from_text.max_cdeg(), 18000);
  EXPECT_EQ(from_text.moves(), 2u);

  // The stream's repeated field, its clock and its enum: what the calls above left.
  Received received;
  Stream watch = client.open_stream("Watch", arm::StateRequest(), 20ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 1; }));
  {
    std::lock_guard lock(received.mutex);
    const arm::State& state = received.states.front();
    ASSERT_EQ(state.angles_cdeg_size(), 4);
    EXPECT_EQ(state.angles_cdeg(0), 0);
    EXPECT_EQ(state.angles_cdeg(1), 12345);
    EXPECT_EQ(state.angles_cdeg(2), -4500);
    EXPECT_EQ(state.angles_cdeg(3), 0);
    EXPECT_EQ(state.mode(), arm::MODE_ACTIVE);
    EXPECT_GT(state.millis(), 0u);
  }
  watch.close();
  EXPECT_EQ(client.counters().device_errors, 1u);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

TEST(RpcInterop, AHandlersErrorReachesTheCallerWithItsCodeAndText) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  error_code error;
  CallResult result = client.call("MoveJoint", joint_request(7, 0), error);
  EXPECT_EQ(error, RpcError::device_error) << error.message();
  EXPECT_EQ(result.device_error.code, 1);
  EXPECT_EQ(result.device_error.text, "no joint");
  EXPECT_EQ(result.reply, nullptr);

  result = client.call("MoveJoint", joint_request(0, 18001), error);
  EXPECT_EQ(error, RpcError::device_error);
  EXPECT_EQ(result.device_error.code, 2);
  EXPECT_EQ(result.device_error.text, "out of range");

  arm::ModeRequest inverted;
  inverted.mutable_range()->set_min_cdeg(100);
  inverted.mutable_range()->set_max_cdeg(-100);
  result = client.call("SetMode", inverted, error);
  EXPECT_EQ(error, RpcError::device_error);
  EXPECT_EQ(result.device_error.code, 2);
  EXPECT_EQ(result.device_error.text, "out of range");

  arm::ModeRequest hold;
  hold.set_mode(arm::MODE_HOLD);
  EXPECT_EQ(as<arm::ModeReply>(*client.call("SetMode", hold).reply).previous(), arm::MODE_IDLE);
  try {
    client.call_json("MoveJoint", R"({"joint": 0, "angleCdeg": 100})");
    ADD_FAILURE() << "no exception";
  } catch (const CallError& e) {
    EXPECT_EQ(e.code(), RpcError::device_error);
    EXPECT_EQ(e.device_error().code, 3);
    EXPECT_EQ(e.device_error().text, "on hold");
    EXPECT_STREQ(e.what(), "MoveJoint: device error 3: on hold");
  }
  // Nothing of the refused moves ran.
  EXPECT_EQ(as<arm::Description>(*client.call("Describe", arm::DescribeRequest()).reply).moves(), 0u);
  EXPECT_EQ(client.counters().device_errors, 4u);
  client.close();
}

TEST(RpcInterop, AStreamSendsAtItsPeriodWithIncreasingSeqUntilClosed) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  auto& uno = stream->board();
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  Received received;
  Stream watch = client.open_stream("Watch", arm::StateRequest(), 20ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 10; }));
  watch.close();
  EXPECT_FALSE(watch.is_open());
  std::size_t at_close = 0;
  {
    std::lock_guard lock(received.mutex);
    at_close = received.seqs.size();
    for (std::size_t i = 0; i < received.seqs.size(); ++i) EXPECT_EQ(received.seqs[i], i) << "message " << i;
    // The device's clock in the messages: one period apart (its poll runs every millisecond). The first
    // goes at the first poll after the open, once the ack is written, and the period counts from the open.
    for (std::size_t i = 2; i < received.states.size(); ++i) {
      const std::uint32_t step = received.states[i].millis() - received.states[i - 1].millis();
      EXPECT_GE(step, 19u) << "message " << i;
      EXPECT_LE(step, 21u) << "message " << i;
    }
    EXPECT_TRUE(received.ends.empty());
  }
  // Closed: after ten periods of the board's time, nothing more came (at most one already on the wire).
  let_board_run(uno, 200ms);
  EXPECT_LE(received.count(), at_close + 1);
  const std::size_t settled = received.count();
  let_board_run(uno, 200ms);
  EXPECT_EQ(received.count(), settled);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

// The image's shortest period is one frame of its largest stream message at 115200 baud (76 bytes: 7 ms):
// 6 ms is refused, 7 ms streams.
TEST(RpcInterop, AStreamPeriodShorterThanOneFrameTimeIsRefused) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  Received refused;
  Stream too_fast = client.open_stream("Watch", arm::StateRequest(), 6ms, refused.handler());
  ASSERT_TRUE(wait_for([&] {
    std::lock_guard lock(refused.mutex);
    return !refused.ends.empty();
  }));
  {
    std::lock_guard lock(refused.mutex);
    EXPECT_EQ(refused.ends[0], RpcError::refused) << refused.ends[0].message();
    EXPECT_EQ(refused.end_texts[0], "period too short");
    EXPECT_TRUE(refused.seqs.empty());
  }
  Received received;
  Stream fastest = client.open_stream("Watch", arm::StateRequest(), 7ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 5; }));
  fastest.close();
  client.close();
}

TEST(RpcInterop, AWatchdogResetMidStreamIsDetectedAndTheStreamResumesWithoutTheApplication) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  auto& uno = stream->board();
  EventLog log;
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream), log.handler());
  client.wait_ready();
  client.call("MoveJoint", joint_request(3, 900));
  const std::uint32_t first_session = *client.session().session_id;
  Received received;
  Stream watch = client.open_stream("Watch", arm::StateRequest(), 20ms, received.handler());
  ASSERT_TRUE(wait_for([&] { return received.count() >= 5; }));
  uno.reset(transports::ResetKind::watchdog);  // behind the host's back
  ASSERT_TRUE(wait_for([&] { return log.of<events::SessionEstablished>().size() >= 2; }));
  ASSERT_GE(log.of<events::ResetDetected>().size(), 1u);
  EXPECT_EQ(log.of<events::ResetDetected>()[0].previous, first_session);
  EXPECT_EQ(log.of<events::SessionEstablished>()[1].streams_reopened, 1u);
  EXPECT_FALSE(log.of<events::SessionEstablished>()[1].first);
  EXPECT_NE(*client.session().session_id, first_session);
  // The stream goes on by itself: seq from 0 again on the rebooted device, which forgot the move.
  ASSERT_TRUE(wait_for([&] {
    std::lock_guard lock(received.mutex);
    const auto restart = std::find(received.seqs.begin() + 1, received.seqs.end(), 0u);
    return restart != received.seqs.end() && received.seqs.end() - restart >= 3;
  }));
  {
    std::lock_guard lock(received.mutex);
    const auto restart = std::find(received.seqs.begin() + 1, received.seqs.end(), 0u);
    for (auto it = restart + 1; it != received.seqs.end(); ++it) EXPECT_EQ(*it, *(it - 1) + 1);
    EXPECT_EQ(received.states.front().angles_cdeg(3), 900);
    EXPECT_EQ(received.states.back().angles_cdeg(3), 0);
    EXPECT_TRUE(received.ends.empty());
  }
  EXPECT_TRUE(watch.is_open());
  EXPECT_GE(client.counters().link.resets, 1u);
  // And the application carries on.
  EXPECT_EQ(as<arm::JointReply>(*client.call("MoveJoint", joint_request(3, 1000)).reply).reached_cdeg(), 1000);
  watch.close();
  client.close();
}

TEST(RpcInterop, ADeviceOfAnotherSchemaIsRefusedNamingBothHashes) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  EventLog log;
  const std::uint64_t device_hash = Schema::load(kArmSchema).hash();
  const std::uint64_t other_hash = Schema::load(kOtherSchema).hash();
  ASSERT_NE(device_hash, other_hash);
  Client client(stream, Schema::load(kOtherSchema), on_board_time(stream), log.handler());
  try {
    client.wait_ready();
    ADD_FAILURE() << "no exception";
  } catch (const boost::system::system_error& e) {
    EXPECT_EQ(e.code(), RpcError::schema_mismatch);
    const std::string text = e.what();
    EXPECT_NE(text.find(format_hash(device_hash)), std::string::npos) << text;
    EXPECT_NE(text.find(format_hash(other_hash)), std::string::npos) << text;
    EXPECT_NE(text.find("other_arm.proto"), std::string::npos) << text;
  }
  ASSERT_FALSE(log.of<events::SchemaMismatch>().empty());
  EXPECT_EQ(log.of<events::SchemaMismatch>()[0].device_hash, device_hash);
  EXPECT_EQ(log.of<events::SchemaMismatch>()[0].schema_hash, other_hash);
  error_code error;
  client.call("MoveJoint", *client.new_request("MoveJoint"), error);
  EXPECT_EQ(error, RpcError::schema_mismatch);
  EXPECT_FALSE(client.session().established);
  client.close();
}

TEST(RpcInterop, UnderLineNoiseNoCallRunsTwiceAndNoAnswerIsWrong) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  auto& uno = stream->board();
  Client client(stream, Schema::load(kArmSchema), on_board_time(stream));
  client.wait_ready();
  MoveWitness witness(uno);
  witness.read();
  transports::FaultConfig noise;
  noise.bit_error_rate = 5e-4;
  noise.drop_rate = 2e-3;
  uno.set_faults(transports::Direction::to_mcu, noise);
  uno.set_faults(transports::Direction::from_mcu, noise);
  // Distinct (joint, angle) pairs: a call that ran twice shows as a key counted twice by the witness.
  int answered = 0;
  int wrong = 0;
  int failed = 0;
  std::map<std::uint32_t, bool> confirmed;  // by key: the caller got the reply
  constexpr int kCalls = 120;
  for (int i = 0; i < kCalls; ++i) {
    const auto joint = static_cast<std::uint32_t>(i % 4);
    const std::int32_t angle = -6000 + 100 * i;
    error_code error;
    const CallResult result = client.call("MoveJoint", joint_request(joint, angle), error);
    if (!error) {
      ++answered;
      confirmed[move_key(joint, angle)] = true;
      if (as<arm::JointReply>(*result.reply).reached_cdeg() != angle) ++wrong;
    } else {
      ++failed;
      confirmed[move_key(joint, angle)] = false;
      EXPECT_EQ(error, RpcError::timed_out) << "call " << i << ": " << error.message();
    }
    witness.read();  // after each call: far fewer than kWitnessLogSize runs between two reads
  }
  uno.set_faults(transports::Direction::to_mcu, transports::FaultConfig());
  uno.set_faults(transports::Direction::from_mcu, transports::FaultConfig());
  let_board_run(uno, 100ms);
  witness.read();
  int twice = 0;
  for (const auto& [key, runs] : witness.runs) {
    if (runs > 1) ++twice;
    EXPECT_EQ(runs, 1) << "key " << std::hex << key << " ran " << runs << " times";
  }
  int confirmed_not_run = 0;
  for (const auto& [key, ok] : confirmed) {
    if (ok && witness.runs.count(key) == 0) ++confirmed_not_run;
  }
  const auto stats = uno.stats();
  const Counters counters = client.counters();
  std::printf("noise: %d of %d answered, %d failed, %zu executed, %d twice, %d wrong answers, %u unobserved, "
              "re-sends %u, crc errors %u, flips %llu, drops %llu\n",
              answered, kCalls, failed, witness.runs.size(), twice, wrong, witness.unobserved, counters.link.retries,
              counters.link.crc_errors,
              static_cast<unsigned long long>(stats.to_mcu.bits_flipped + stats.from_mcu.bits_flipped),
              static_cast<unsigned long long>(stats.to_mcu.bytes_dropped + stats.from_mcu.bytes_dropped));
  EXPECT_EQ(twice, 0);
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(confirmed_not_run, 0);
  EXPECT_EQ(witness.unobserved, 0u);
  EXPECT_GT(answered, kCalls * 3 / 4);
  EXPECT_GT(counters.link.retries, 0u);  // the noise did cost re-sends
  // The device agrees on how many ran.
  EXPECT_EQ(as<arm::Description>(*client.call("Describe", arm::DescribeRequest()).reply).moves(), witness.runs.size());
  client.close();
}

// The image's deepest stack over everything it does (every method, an error, the stream, its own hello)
// with the free SRAM painted: the static data and that peak must leave room unused.
TEST(RpcInterop, PeakStackOverEveryMethodLeavesRamUnused) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board());
  Options options = on_board_time(stream);
  options.timing.ping_period = 0;  // the device idle across the paint
  Client client(stream, Schema::load(kArmSchema), options);
  uno_testing::expect_ram_unused_after_everything(client, stream->board(), "rpc-example");
  client.close();
}

}  // namespace
}  // namespace tether::rpc
