// Each codec's own recovery after its serial port vanished and came back under another path
// (unpluggable_board.hpp; romi's is reconnect_test.cpp). A real unplug of a USB-powered Uno also
// power-cycles it, so the board is power-cycled during the outage: the device's session is gone and the
// host client must start it again by itself. proxy: a new session handshake, the configured inits replayed
// (the pin they set is set again), sends acked; rpc: the open stream opened again on the device without
// the application (its messages come again), calls run exactly once; elcano: the ring's requests resume.
#include <gtest/gtest.h>

#include <boost/asio/use_future.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/exactly_once.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/elcano/client.hpp"
#include "tether/proxy/client.hpp"
#include "tether/rpc/client.hpp"
#include "tether/transports/virtual_uno.hpp"
#include "proxy_session_log.hpp"
#include "unpluggable_board.hpp"

namespace tether::devices {
namespace {

using namespace std::chrono_literals;
using testing::EventLog;
using testing::ProxySessionLog;
using testing::UnpluggableBoard;
using testing::wait_until;
using transports::TransportError;

class DevicesReconnectCodecs : public testing::ReconnectTest {};

// The port's link events from now on.
std::shared_ptr<EventLog> watch_link(const RoverDevice& device) {
  auto events = std::make_shared<EventLog>();
  device.port->add_link_handler([events](const transports::LinkEvent& event) { events->add(event); });
  return events;
}

TEST_F(DevicesReconnectCodecs, AProxyDeviceGetsANewSessionAndItsInitsAfterAPowerCycleOutage) {
  UnpluggableBoard* const uno = start("proxy");
  if (uno == nullptr) GTEST_SKIP() << "proxy image not built";
  auto witness = demo::ExecutionWitness::attach(uno->board());
  ASSERT_TRUE(witness);
  Rover rover = open_rover(parse_config(testing::serial_device_config(
                               "proxy", R"({"inits": [{"kind": "servo", "pin": 9, "safe_position": 90},
                                                      {"kind": "digital", "pin": 13, "safe_state": true}]})")),
                           io.executor());
  const RoverDevice& device = rover.devices().at(0);
  ASSERT_TRUE(device.port);
  const auto events = watch_link(device);
  const auto client = rover.client<proxy::Client>("dev");
  ProxySessionLog sessions(*client);
  ASSERT_TRUE(client->session().established);
  const std::uint32_t first_session = client->session().session_id.value_or(0);
  EXPECT_TRUE(uno->board().pin(13).output && uno->board().pin(13).level) << "the digital init at the open";
  (void)witness->read();

  std::set<std::uint32_t> confirmed;
  ASSERT_TRUE(client->servo(9).set(100).acked);
  confirmed.insert(witness_key(9, 100));

  // A send in flight when the port vanishes (held: it never reaches the board), then one during the outage.
  uno->hold(true);
  auto in_flight = client->servo(9).async_set(101, boost::asio::use_future);
  ASSERT_TRUE(uno->wait_held(1));
  uno->unplug();
  EXPECT_EQ(events->wait(1).kind, transports::LinkEvent::Kind::down);
  try {
    in_flight.get();
    ADD_FAILURE() << "the send in flight completed";
  } catch (const boost::system::system_error& error) {
    EXPECT_EQ(error.code(), make_error_code(TransportError::disconnected)) << error.what();
  }
  boost::system::error_code error;
  client->servo(9).set(102, error);
  EXPECT_EQ(error, make_error_code(TransportError::disconnected));
  EXPECT_FALSE(client->session().established);

  // Unplugged, the board loses power: its session and its pin setup are gone.
  const demo::ExecutionWitness::Reading before = witness->read();
  EXPECT_EQ(std::multiset<std::uint32_t>(before.keys.begin(), before.keys.end()),
            std::multiset<std::uint32_t>(confirmed.begin(), confirmed.end()));
  uno->power_cycle();
  EXPECT_FALSE(uno->board().pin(13).output);

  uno->hold(false);
  uno->plug();
  EXPECT_EQ(events->wait(2).kind, transports::LinkEvent::Kind::up);
  // The client restarts the session by itself: handshake, the two inits replayed, a new session id.
  ASSERT_TRUE(sessions.wait_first());
  EXPECT_FALSE(sessions.sessions().front().first);
  EXPECT_EQ(sessions.sessions().front().inits, 2u);
  EXPECT_TRUE(client->session().established);
  EXPECT_NE(client->session().session_id.value_or(0), first_session);
  EXPECT_TRUE(uno->board().pin(13).output && uno->board().pin(13).level) << "the digital init replayed";

  const proxy::SendResult after = client->servo(9).set(110, error);
  EXPECT_FALSE(error) << error.message();
  EXPECT_TRUE(after.acked);
  const demo::ExecutionWitness::Reading reading = witness->read();
  EXPECT_TRUE(reading.rebooted);
  EXPECT_EQ(reading.unobserved, 0u);
  EXPECT_EQ(std::multiset<std::uint32_t>(reading.keys.begin(), reading.keys.end()),
            std::multiset<std::uint32_t>{witness_key(9, 110)});
  rover.close();
}

// A board that kept its power (a cable between a hub and the host, say) still holds its session: the
// client cannot know, runs the handshake all the same, and its sends go again.
TEST_F(DevicesReconnectCodecs, AProxyDeviceThatKeptItsPowerIsUsableAgainAfterTheOutage) {
  UnpluggableBoard* const uno = start("proxy");
  if (uno == nullptr) GTEST_SKIP() << "proxy image not built";
  Rover rover = open_rover(parse_config(testing::serial_device_config(
                               "proxy", R"({"inits": [{"kind": "digital", "pin": 13, "safe_state": true}]})")),
                           io.executor());
  const auto events = watch_link(rover.devices().at(0));
  const auto client = rover.client<proxy::Client>("dev");
  ASSERT_TRUE(client->servo(9).init(90).acked);
  uno->unplug();
  EXPECT_EQ(events->wait(1).kind, transports::LinkEvent::Kind::down);
  uno->plug();
  EXPECT_EQ(events->wait(2).kind, transports::LinkEvent::Kind::up);
  boost::system::error_code error;
  const proxy::SendResult set = client->servo(9).set(120, error);
  EXPECT_FALSE(error) << error.message();
  EXPECT_TRUE(set.acked);
  EXPECT_TRUE(client->session().established);
  rover.close();
}

// Stream messages and stream ends, for waiting on them.
struct StreamLog {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t messages = 0;
  std::vector<boost::system::error_code> ends;

  rpc::StreamHandler handler() {
    return [this](const boost::system::error_code& error, const rpc::StreamMessage& message) {
      std::lock_guard lock(mutex);
      if (error || !message.message) {
        ends.push_back(error);
      } else {
        ++messages;
      }
      changed.notify_all();
    };
  }
  std::size_t count() {
    std::lock_guard lock(mutex);
    return messages;
  }
  bool wait_for_more_than(std::size_t count) {
    std::unique_lock lock(mutex);
    return changed.wait_for(lock, testing::kHangLimit, [&] { return messages > count; });
  }
};

TEST_F(DevicesReconnectCodecs, AnRpcDeviceGetsItsStreamBackAndRunsEachCallOnceAfterAPowerCycleOutage) {
  UnpluggableBoard* const uno = start("rpc-example");
  if (uno == nullptr) GTEST_SKIP() << "rpc-example image not built";
  auto witness = demo::ExecutionWitness::attach(uno->board());
  ASSERT_TRUE(witness);
  const std::string schema = testing::firmware_image("rpc-example").replace_extension(".proto").string();
  Rover rover = open_rover(parse_config(testing::serial_device_config("rpc", R"({"schema": ")" + schema + R"("})")),
                           io.executor());
  const RoverDevice& device = rover.devices().at(0);
  ASSERT_TRUE(device.port);
  const auto events = watch_link(device);
  const auto client = rover.client<rpc::Client>("dev");
  (void)witness->read();

  StreamLog watched;
  rpc::Stream stream = client->open_stream("Watch", *client->new_request("Watch"), 20ms, watched.handler());
  ASSERT_TRUE(watched.wait_for_more_than(1));
  EXPECT_EQ(client->call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 1000})"), R"({"reachedCdeg":1000})");

  uno->unplug();
  EXPECT_EQ(events->wait(1).kind, transports::LinkEvent::Kind::down);
  const auto request = client->new_request("MoveJoint");
  request->ParseFromString(std::string());
  boost::system::error_code error;
  (void)client->call("MoveJoint", *request, error);
  EXPECT_EQ(error, make_error_code(TransportError::disconnected));
  const demo::ExecutionWitness::Reading before = witness->read();
  EXPECT_EQ(before.keys, std::vector<std::uint32_t>{witness_key(1, 1000)});
  uno->power_cycle();

  // The stream is still the application's: nothing ended it, and it comes back by itself.
  const std::size_t seen = watched.count();
  uno->plug();
  EXPECT_EQ(events->wait(2).kind, transports::LinkEvent::Kind::up);
  EXPECT_TRUE(watched.wait_for_more_than(seen + 1)) << "no stream message after the return";
  {
    std::lock_guard lock(watched.mutex);
    EXPECT_TRUE(watched.ends.empty()) << watched.ends.front().message();
  }
  EXPECT_TRUE(stream.is_open());
  EXPECT_EQ(client->call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 2000})"), R"({"reachedCdeg":2000})");

  // Exactly once: the one call since the power cycle ran once (the witness, and the example's own count).
  const demo::ExecutionWitness::Reading reading = witness->read();
  EXPECT_TRUE(reading.rebooted);
  EXPECT_EQ(reading.unobserved, 0u);
  EXPECT_EQ(reading.keys, std::vector<std::uint32_t>{witness_key(1, 2000)});
  EXPECT_NE(client->call_json("Describe", "{}").find(R"("moves":1)"), std::string::npos);
  stream.close();
  rover.close();
}

// The reference ring's boards (rover-virtual.json): goal -> board 1 -> segment -> board 2 -> drive ->
// board 3 -> sensor -> host.
std::vector<testing::BoardImage> reference_ring() {
  ParseOptions options;
  options.firmware_dir = TETHER_FIRMWARE_DIR;
  const RoverConfig config = parse_config(R"({"devices": [{"name": "ring", "codec": "elcano", "transport": {
      "virtual_ring": {"boards": [
        {"eeprom": {"capture": ["goal"], "behaviours": ["answer_goal_with_segment"]}},
        {"eeprom": {"capture": ["sensor", "segment"], "behaviours": ["answer_segment_with_drive", "answer_sensor_with_drive"]}},
        {"eeprom": {"capture": ["drive"], "behaviours": ["drive_servos", "report_drive_as_sensor"]}}]}}}]})",
                                          options);
  std::vector<testing::BoardImage> images;
  for (const RingBoardConfig& board : std::get<VirtualRingTransport>(config.devices.at(0).transport).boards) {
    images.push_back(testing::BoardImage{board.firmware, board.eeprom});
  }
  return images;
}

TEST_F(DevicesReconnectCodecs, AnElcanoRingsRequestsResumeWhenTheHostsPortComesBack) {
  UnpluggableBoard* const ring_boards = start(reference_ring());
  if (ring_boards == nullptr) GTEST_SKIP() << "elcano-node image not built";
  Rover rover = open_rover(
      parse_config(testing::serial_device_config("elcano", R"({"generation": "B", "capture": ["sensor"]})")),
      io.executor());
  const RoverDevice& device = rover.devices().at(0);
  ASSERT_TRUE(device.port);
  const auto events = watch_link(device);
  const auto ring = rover.client<elcano::RingClient>("dev");
  const auto goal = [](std::int32_t number) { return elcano::Message::goal(number, 90, 100, 200); };

  EXPECT_EQ(ring->request(goal(1), elcano::Type::sensor).speed, 150);

  ring_boards->unplug();
  EXPECT_EQ(events->wait(1).kind, transports::LinkEvent::Kind::down);
  boost::system::error_code error;
  (void)ring->request(goal(2), elcano::Type::sensor, error);
  EXPECT_EQ(error, make_error_code(TransportError::disconnected));

  ring_boards->plug();
  EXPECT_EQ(events->wait(2).kind, transports::LinkEvent::Kind::up);
  const elcano::Message sensor = ring->request(goal(3), elcano::Type::sensor, error);
  EXPECT_FALSE(error) << error.message();
  EXPECT_EQ(sensor.type, elcano::Type::sensor);
  EXPECT_EQ(sensor.speed, 150);
  EXPECT_EQ(sensor.angle, 45);
  rover.close();
}

}  // namespace
}  // namespace tether::devices
