// The Arduino libraries' example sketches, built by arduino-builder (the arduino.build.* tests), on the
// virtual Uno, driven by Tether's host: the sketches use the Arduino core's Serial and millis(), not Tether's
// runtime, so these check the libraries as an Arduino user gets them.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>

#include "ring_harness.hpp"
#include "tether/client/testing/event_log.hpp"
#include "tether/proxy/client.hpp"
#include "tether/romi/client.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::arduino {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using transports::IoThread;
using transports::Pacing;
using transports::VirtualUnoOptions;
using transports::VirtualUnoStream;

// build/arduino/sketches/<Library>.<Example>.elf, written by the arduino.build.* test of that example.
std::filesystem::path sketch(const std::string& name) {
  return std::filesystem::path(TETHER_ARDUINO_SKETCH_DIR) / (name + ".elf");
}

VirtualUnoOptions board(const std::string& name, Pacing pacing) {
  VirtualUnoOptions options;
  options.firmware = sketch(name);
  options.pacing = pacing;
  options.seed = tether::testing::random_seed();
  return options;
}

template <typename Predicate>
bool wait_for(Predicate predicate, std::chrono::milliseconds limit = 20s) {
  return tether::testing::eventually(predicate, limit);
}

// --- TetherRomi: the RomiSerial README's sketches, unchanged ---------------------------------------------

TEST(TetherRomiBlink, LOneLightsTheLedAndLZeroTurnsItOff) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("TetherRomi.Blink", Pacing::fast));
  romi::Client client(stream);
  EXPECT_EQ(client.call("L[1]").values, json::parse("[0]"));
  EXPECT_TRUE(stream->board().digital_level(13));
  EXPECT_EQ(client.call("L[0]").values, json::parse("[0]"));
  EXPECT_FALSE(stream->board().digital_level(13));
  // An opcode the table lacks gets the protocol's error, not silence.
  EXPECT_EQ(client.call("Z").code, -16);
}

TEST(TetherRomiAnalogReadSerial, AAnswersTheConversionOfA0) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("TetherRomi.AnalogReadSerial", Pacing::fast));
  romi::Client client(stream);
  stream->board().set_analog_input(0, 2.5);
  const json half = client.call("A").values;
  ASSERT_EQ(half.size(), 2u) << half;
  EXPECT_EQ(half[0], 0);
  EXPECT_NEAR(half[1].get<int>(), 512, 2);
  stream->board().set_analog_input(0, 5.0);
  EXPECT_EQ(client.call("A").values, json::parse("[0,1023]"));
}

// --- Two libraries in one sketch (tests/together/) -------------------------------------------------------

// TetherRomi on Serial and TetherElcano's node on a SoftwareSerial: the sketch links (each library once
// bundled Tether's core, and the link failed on its functions defined twice) and both run: the Romi side
// answers, the node polls its idle port.
TEST(TetherTogether, RomiAndElcanoInOneSketchBothRun) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("together.RomiAndElcano", Pacing::fast));
  romi::Client client(stream);
  EXPECT_EQ(client.call("L[1]").values, json::parse("[0]"));
  EXPECT_TRUE(stream->board().digital_level(13));
  // No drive captured; the node's last outcome is `unavailable` (6): it ran and found nothing on its port.
  EXPECT_EQ(client.call("R").values, json::parse("[0,0,6]"));
  EXPECT_EQ(client.call("L[0]").values, json::parse("[0]"));
  EXPECT_FALSE(stream->board().digital_level(13));
}

// --- TetherProxy: the proxy / proxy-compat images as sketches ----------------------------------------------

double servo_pulse_us(transports::VirtualUno& uno) {
  return std::chrono::duration<double, std::micro>(uno.pulse_timing(9).high_time).count();
}

using EventLog = client::testing::EventLog<proxy::Event>;

TEST(TetherProxyProxy, AcksMovesTheServoOnD9AndTheDigitalPin) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("TetherProxy.Proxy", Pacing::fast));
  auto& uno = stream->board();
  proxy::Client client(stream);
  client.servo(9).init(90);  // each blocks until acked (throws otherwise)
  client.digital(13).init(false);
  ASSERT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1500.0) < 5.0; })) << servo_pulse_us(uno);
  client.servo(9).set(180);
  client.digital(13).set(true);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 2000.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(uno.digital_level(13));
  // A 20 ms servo period (Timer1 mode 14), not the Arduino core's 490 Hz analogWrite PWM on D9. In simavr the
  // period measured across a width change can be short (the driver restarts Timer1's clock so that simavr
  // applies the new OCR1A: runtime/src/servo_timer1.cpp), so the test waits for a whole period at the new
  // width (reading it once, right after the width changed, failed about 1 run in 3 on a loaded machine).
  const auto period_ms = [&uno] { return std::chrono::duration<double, std::milli>(uno.pulse_timing(9).period).count(); };
  EXPECT_TRUE(wait_for([&] { return std::abs(period_ms() - 20.0) < 0.1; })) << period_ms();
  EXPECT_TRUE(client.session().established);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

TEST(TetherProxyProxy, WithoutPingsThePinsGoSafeAfterTenSecondsOfSimulatedTime) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("TetherProxy.Proxy", Pacing::fast));
  auto& uno = stream->board();
  proxy::Options options;
  options.timing.ping_period = 0;  // the host stops pinging
  EventLog log;
  proxy::Client client(stream, options);
  client.on_event(log.handler());
  client.servo(9).init(45);
  client.digital(13).init(false);
  client.servo(9).set(170);
  client.digital(13).set(true);
  ASSERT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1944.0) < 5.0; })) << servo_pulse_us(uno);
  ASSERT_LT(uno.simulated_time(), 10s) << "the handshake took too long to test the 10 s rule";
  ASSERT_TRUE(wait_for([&] { return !log.of<proxy::events::FailsafeTriggered>().empty(); }, 60s));
  // Safe values (servo 45 degrees = 1250 us, D13 low), never before 10 s of silence.
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1250.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_FALSE(uno.digital_level(13));
  EXPECT_GE(uno.pulse_timing(13).last_edge, 10s);
  client.close();
}

TEST(TetherProxyProxyCompat, TheDeployedHostsProtocolMovesTheServoWithServoLibraryTiming) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("TetherProxy.ProxyCompat", Pacing::fast));
  auto& uno = stream->board();
  EventLog log;
  proxy::Client client(stream, proxy::Options::compat(), log.handler());
  ASSERT_TRUE(wait_for([&] {
    for (const auto& event : log.of<proxy::events::CompatEvent>()) {
      if (event.type == ::RocketryProto::RESET) return true;
    }
    return false;
  }));
  client.servo(9).init(90);
  client.digital(8).init(false);  // not D13: the load cell's clock in compat mode
  client.servo(9).set(180);
  client.digital(8).set(true);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 2400.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(wait_for([&] { return uno.digital_level(8); }));
  // The state stream reports the pin; a control of an uninitialised pin is the deployed error.
  EXPECT_TRUE(wait_for([&] {
    const auto state = client.pin_state(proxy::PinKind::digital, 8);
    return state && state->has_value && state->value == 1;
  }));
  client.digital(7).set(true);
  EXPECT_TRUE(wait_for([&] {
    for (const auto& error : log.of<proxy::events::CompatError>()) {
      if (error.type == ::RocketryProto::PIN_NOT_INITIALIZED && error.data == 7) return true;
    }
    return false;
  }));
  client.close();
}

// --- TetherElcano: the sketch as the middle board of a ring with two elcano-node boards -------------------

namespace interop = tether::elcano::interop;

// host -> elcano-node (forwards all) -> SKETCH -> elcano-node (forwards all) -> host (captures sensors).
interop::RingOptions ring_with(const std::string& name) {
  interop::RingOptions options;
  options.boards = {interop::node_config(1, 0, 0), interop::node_config(2, 0, 0), interop::node_config(3, 0, 0)};
  options.images = {{}, sketch(name), {}};
  options.seed = tether::testing::random_seed();
  return options;
}

TEST(TetherElcanoDriveNode, CapturesDrivesAnswersWithSensorReportsAndForwardsTheRest) {
  interop::Ring ring(ring_with("TetherElcano.DriveNode"));
  ring.run(100ms);  // boot
  ASSERT_EQ(ring.send(elcano::Message::drive(50, 25)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(elcano::RingEvent::Kind::captured, elcano::Type::sensor) == 1; }, 1s));
  const interop::HostEvent& report = ring.events().back();
  EXPECT_TRUE(report.event.message == elcano::Message::sensor(50, 25, 0, 0, 0))
      << interop::describe(report.event.message);
  EXPECT_TRUE(ring.board(1).digital_level(13));  // the sketch's reaction: moving
  ASSERT_EQ(ring.send(elcano::Message::drive(0, -10)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(elcano::RingEvent::Kind::captured, elcano::Type::sensor) == 2; }, 1s));
  EXPECT_TRUE(ring.events().back().event.message == elcano::Message::sensor(0, -10, 0, 0, 0));
  EXPECT_FALSE(ring.board(1).digital_level(13));
  // A goal nobody captures goes round through the sketch and comes back to the host, unchanged.
  ASSERT_EQ(ring.send(elcano::Message::goal(3, 679, -23456, 123450)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(elcano::RingEvent::Kind::undeliverable, elcano::Type::goal) == 1; }, 1s));
  EXPECT_TRUE(ring.events().back().event.message == elcano::Message::goal(3, 679, -23456, 123450));
  // Nothing was captured by the host but the two reports, and no drive came round.
  ring.run(300ms);
  EXPECT_EQ(ring.count(elcano::RingEvent::Kind::captured), 2u);
  EXPECT_EQ(ring.count(elcano::RingEvent::Kind::undeliverable, elcano::Type::drive), 0u);
  EXPECT_EQ(ring.host_link().crc_errors + ring.host_link().framing_errors, 0u);
}

TEST(TetherElcanoSkeleton, TheReadmeSkeletonCapturesDrivesAndForwardsEverythingElse) {
  interop::Ring ring(ring_with("TetherElcano.Skeleton"));
  ring.run(100ms);
  // A sensor and a segment from the host go round (the host captures sensors: it takes its own one back).
  ASSERT_EQ(ring.send(elcano::Message::segment(1, 1599, 270, 14263, 123456)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(elcano::RingEvent::Kind::undeliverable, elcano::Type::segment) == 1; }, 1s));
  EXPECT_TRUE(ring.events().back().event.message == elcano::Message::segment(1, 1599, 270, 14263, 123456));
  // A drive is consumed by the sketch: it never comes back, its origin record expires at the host.
  ASSERT_EQ(ring.send(elcano::Message::drive(259, -3)), Status::ok);
  ring.run(3s);
  EXPECT_EQ(ring.count(elcano::RingEvent::Kind::undeliverable, elcano::Type::drive), 0u);
  EXPECT_EQ(ring.host_ring().origins_expired, 1u);
  // The ring still carries messages after that.
  ASSERT_EQ(ring.send(elcano::Message::goal(2, 679, 0, 0)), Status::ok);
  EXPECT_TRUE(ring.run_until([&] { return ring.count(elcano::RingEvent::Kind::undeliverable, elcano::Type::goal) == 1; }, 1s));
}

}  // namespace
}  // namespace tether::arduino
