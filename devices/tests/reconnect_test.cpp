// Supervision of a serial device, end to end: a virtual Uno (romi-rover image, with its execution witness)
// behind a pty named by a stable by-id symlink in a fake tree (unpluggable_board.hpp). The pty is unplugged
// (its master closed, the symlink removed) while the client calls, and comes back under another /dev/pts/N
// behind the same name. Calls in flight and during the outage fail with `disconnected`, the first call after
// the return succeeds, and the witness shows that nothing executed twice (nor anything that failed). No
// sleep decides anything: the test waits for the link events and the bytes it expects, with generous limits
// that only bound a hang. The other codecs' outages: reconnect_codecs_test.cpp.
#include <gtest/gtest.h>

#include <boost/asio/use_future.hpp>

#include <chrono>
#include <cstdint>
#include <set>
#include <string>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/exactly_once.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/romi/client.hpp"
#include "unpluggable_board.hpp"

namespace tether::devices {
namespace {

using namespace std::chrono_literals;
using testing::EventLog;
using testing::kById;
using testing::UnpluggableBoard;

romi::Command servos(int throttle) { return romi::Command('S', {throttle, 1500}); }
std::uint32_t key(int throttle) { return witness_key(static_cast<std::uint16_t>(throttle), 1500); }

// A romi-rover board behind the by-id name kById, in a fake port tree the lookup reads.
class DevicesReconnect : public testing::ReconnectTest {
 protected:
  void SetUp() override {
    board_ = start("romi-rover");
    if (board_ == nullptr) GTEST_SKIP() << "romi-rover image not built";
  }
  UnpluggableBoard& board() { return *board_; }

 private:
  UnpluggableBoard* board_ = nullptr;
};

TEST_F(DevicesReconnect, ARomiDeviceSurvivesItsPortComingBackUnderAnotherPath) {
  UnpluggableBoard& uno = board();
  auto witness = demo::ExecutionWitness::attach(uno.board());
  ASSERT_TRUE(witness);

  const RoverConfig config = parse_config(std::string(R"({"devices": [{"name": "rover", "codec": "romi", "transport":)") +
                                          R"({"serial": {"port": {"by_id": ")" + kById +
                                          R"("}, "boot_wait_ms": 0}}, "options": {"call_budget_ms": 3000,)" +
                                          R"( "attempt_timeout_ms": 1000, "max_attempts": 3}}]})");
  Rover rover = open_rover(config, io.executor());
  (void)witness->read();  // what the boot did is not a call's
  const RoverDevice& device = rover.devices().at(0);
  ASSERT_TRUE(device.port);
  EventLog events;
  device.port->add_link_handler([&events](const transports::LinkEvent& event) { events.add(event); });
  const std::string first_path = device.port->path();
  auto client = rover.client<romi::Client>("rover");

  std::set<std::uint32_t> confirmed;
  std::set<std::uint32_t> failed;
  const auto call = [&](int throttle) {
    error_code error;
    const romi::RomiResponse response = client->call(servos(throttle), error);
    (error || response.code != 0 ? failed : confirmed).insert(key(throttle));
    return error;
  };
  ASSERT_FALSE(call(1100));

  // A call in flight when the port vanishes: its request reached the "wire" but not the board.
  uno.hold(true);
  auto in_flight = client->async_call(servos(1200), boost::asio::use_future);
  ASSERT_TRUE(uno.wait_held(1));
  uno.unplug();
  const transports::LinkEvent down = events.wait(1);
  EXPECT_EQ(down.kind, transports::LinkEvent::Kind::down);
  EXPECT_NE(down.reason.find(first_path), std::string::npos) << down.reason;
  try {
    in_flight.get();
    ADD_FAILURE() << "the call in flight completed";
  } catch (const boost::system::system_error& error) {
    EXPECT_EQ(error.code(), make_error_code(transports::TransportError::disconnected)) << error.what();
  }
  failed.insert(key(1200));

  // During the outage new calls fail at once (well within the call budget).
  const auto before = std::chrono::steady_clock::now();
  EXPECT_EQ(call(1300), make_error_code(transports::TransportError::disconnected));
  EXPECT_EQ(call(1400), make_error_code(transports::TransportError::disconnected));
  EXPECT_LT(std::chrono::steady_clock::now() - before, 1s);  // the budget is 3 s: no call waited for it
  EXPECT_EQ(device.port->link_counters().disconnects, 1u);
  EXPECT_FALSE(device.port->link_counters().up);

  // Back under another pts number behind the same by-id name.
  uno.hold(false);
  const std::string second_path = uno.plug();
  EXPECT_NE(second_path, first_path);
  const transports::LinkEvent up = events.wait(2);
  EXPECT_EQ(up.kind, transports::LinkEvent::Kind::up);
  EXPECT_EQ(up.path, second_path);
  EXPECT_EQ(device.port->path(), second_path);
  EXPECT_FALSE(call(1700));  // the first call after the return succeeds
  EXPECT_FALSE(call(1600));
  const transports::LinkCounters counters = device.port->link_counters();
  EXPECT_EQ(counters.disconnects, 1u);
  EXPECT_EQ(counters.reconnects, 1u);
  EXPECT_TRUE(counters.up);
  EXPECT_EQ(events.size(), 2u);  // one down, one up: no event per failed attempt

  // The witness: exactly the confirmed commands ran, each once; nothing that failed ran.
  const demo::ExecutionWitness::Reading reading = witness->read();
  EXPECT_FALSE(reading.rebooted);
  EXPECT_EQ(reading.unobserved, 0u);
  std::multiset<std::uint32_t> executed(reading.keys.begin(), reading.keys.end());
  EXPECT_EQ(executed, std::multiset<std::uint32_t>(confirmed.begin(), confirmed.end()));
  for (const std::uint32_t each : failed) EXPECT_EQ(executed.count(each), 0u) << each;
  EXPECT_EQ(confirmed.size(), 3u);
  rover.close();
}

TEST_F(DevicesReconnect, WithoutReconnectAVanishedPortEndsTheClient) {
  UnpluggableBoard& uno = board();
  const RoverConfig config = parse_config(std::string(R"({"devices": [{"name": "rover", "codec": "romi", "transport":)") +
                                          R"({"serial": {"port": {"by_id": ")" + kById +
                                          R"("}, "boot_wait_ms": 0, "reconnect": false}}}]})");
  Rover rover = open_rover(config, io.executor());
  auto client = rover.client<romi::Client>("rover");
  EXPECT_EQ(client->call(servos(1100)).code, 0);
  uno.hold(true);
  auto in_flight = client->async_call(servos(1200), boost::asio::use_future);
  ASSERT_TRUE(uno.wait_held(1));
  uno.unplug();
  try {
    in_flight.get();
    ADD_FAILURE() << "the call in flight completed";
  } catch (const boost::system::system_error& error) {
    EXPECT_NE(error.code(), make_error_code(transports::TransportError::disconnected)) << error.what();
  }
  uno.hold(false);
  uno.plug();
  error_code error;
  client->call(servos(1300), error);
  EXPECT_TRUE(error);  // the link stays failed: nothing re-opens it
  EXPECT_EQ(rover.devices().at(0).port->link_counters().disconnects, 0u);
}

}  // namespace
}  // namespace tether::devices
