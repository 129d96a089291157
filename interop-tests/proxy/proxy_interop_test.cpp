// The proxy protocol end to end: ProxyClient against the real proxy / proxy-compat firmware on the
// virtual Uno, checking the simulated pins (servo pulse on D9, level of D13), not only the messages.
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <set>
#include <thread>
#include <variant>
#include <vector>

#include "tether/proxy/client.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::proxy {
namespace {

using namespace std::chrono_literals;
using transports::IoThread;
using transports::Pacing;
using transports::VirtualUnoOptions;
using transports::VirtualUnoStream;

VirtualUnoOptions board(const char* image, Pacing pacing) {
  VirtualUnoOptions options;
  options.firmware = std::string(TETHER_FIRMWARE_DIR) + "/" + image;
  options.pacing = pacing;
  options.seed = tether::testing::random_seed();
  return options;
}

// The high time of D9's last complete pulse, in microseconds (0 before one completed).
double servo_pulse_us(transports::VirtualUno& uno) {
  return std::chrono::duration<double, std::micro>(uno.pulse_timing(9).high_time).count();
}

// Waits (wall time) until `predicate` holds.
template <typename Predicate>
bool wait_for(Predicate predicate, std::chrono::milliseconds limit = 10s) {
  return tether::testing::eventually(predicate, limit);
}

// Records every event.
struct EventLog {
  std::mutex mutex;
  std::vector<ProxyEvent> events;
  EventHandler handler() {
    return [this](const ProxyEvent& event) {
      std::lock_guard lock(mutex);
      events.push_back(event);
    };
  }
  template <typename T>
  std::vector<T> all() {
    std::lock_guard lock(mutex);
    std::vector<T> found;
    for (const auto& event : events) {
      if (const T* value = std::get_if<T>(&event)) found.push_back(*value);
    }
    return found;
  }
};

TEST(ProxyInterop, InitAndControlDriveTheServoPulseAndTheDigitalPin) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("proxy.elf", Pacing::real_time));
  auto& uno = stream->board();
  ProxyClient client(stream);
  client.servo(9).init(90);
  client.digital(13).init(false);
  ASSERT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1500.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_FALSE(uno.digital_level(13));
  client.servo(9).set(180);
  client.digital(13).set(true);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 2000.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(uno.digital_level(13));
  client.servo(9).set(0);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1000.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(client.session().established);
  EXPECT_EQ(client.counters().link.crc_errors, 0u);
  client.close();
}

TEST(ProxyInterop, WithoutPingsThePinsGoSafeAfterTenSecondsAndTheFailsafeIsReported) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("proxy.elf", Pacing::fast));
  auto& uno = stream->board();
  ProxyOptions options;
  options.timing.ping_period = 0;  // the host stops pinging
  EventLog log;
  ProxyClient client(stream, options);
  client.add_event_handler(log.handler());
  client.servo(9).init(45);
  client.digital(13).init(false);
  client.servo(9).set(170);
  client.digital(13).set(true);
  const auto commanded_at = uno.simulated_time();
  ASSERT_LT(commanded_at, 10s) << "the handshake took too long to test the 10 s rule";
  ASSERT_TRUE(wait_for([&] { return !log.all<events::FailsafeTriggered>().empty(); }, 20s));
  // Safe values: servo 45 degrees = 1250 us, D13 low; and never before 10 s of silence since boot.
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1250.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_FALSE(uno.digital_level(13));
  EXPECT_GE(uno.pulse_timing(13).last_edge, 10s);
  // The device reports the sticky flag until PingFailsafeReset clears it.
  client.reset_failsafe();
  client.close();
}

TEST(ProxyInterop, AnMcuResetIsDetectedAndTheInitsAreReplayedWithoutTheApplication) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("proxy.elf", Pacing::real_time));
  auto& uno = stream->board();
  EventLog log;
  ProxyClient client(stream);
  client.add_event_handler(log.handler());
  client.servo(9).init(90);
  client.digital(13).init(true);
  client.servo(9).set(180);
  ASSERT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 2000.0) < 5.0; }));
  const auto first_session = client.session().session_id;
  uno.reset(transports::ResetKind::power_cycle, 20ms);  // behind the host's back
  // The power-up leaves the pins undriven; the replayed inits drive them to their safe values again.
  ASSERT_TRUE(wait_for([&] { return log.all<events::SessionEstablished>().size() >= 2; }, 15s));
  EXPECT_GE(log.all<events::ResetDetected>().size(), 1u);
  EXPECT_FALSE(log.all<events::SessionEstablished>().back().first);
  EXPECT_NE(client.session().session_id, first_session);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1500.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(uno.digital_level(13));
  EXPECT_GE(client.counters().link.resets, 1u);
  client.servo(9).set(0);  // and the application carries on
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 1000.0) < 5.0; }));
  client.close();
}

TEST(ProxyInterop, UnderLineNoiseEveryAckedCommandRanExactlyOnce) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("proxy.elf", Pacing::real_time));
  auto& uno = stream->board();
  EventLog log;
  ProxyClient client(stream);
  client.add_event_handler(log.handler());
  client.servo(9).init(0);
  transports::FaultConfig noise;
  noise.bit_error_rate = 5e-4;
  noise.drop_rate = 2e-3;
  uno.set_faults(transports::Direction::to_mcu, noise);
  uno.set_faults(transports::Direction::from_mcu, noise);
  // Distinct positions: a command executed twice would show up as a repeated position in the device's
  // PinState reports (it reports every executed control once; a repeated messageId gets only an ack).
  int acked = 0;
  int last_acked_position = -1;
  for (int position = 2; position <= 180; position += 2) {
    error_code error;
    client.servo(9).set(position, error);
    if (!error) {
      ++acked;
      last_acked_position = position;
    }
  }
  uno.set_faults(transports::Direction::to_mcu, transports::FaultConfig());
  uno.set_faults(transports::Direction::from_mcu, transports::FaultConfig());
  std::this_thread::sleep_for(200ms);
  std::multiset<int> reported;
  for (const auto& report : log.all<events::PinReport>()) {
    if (report.pin == 9 && !report.failsafe && report.value != 0) reported.insert(report.value);
  }
  for (int value : reported) EXPECT_EQ(reported.count(value), 1u) << "position " << value << " executed twice";
  const auto stats = uno.stats();
  std::printf("noise: %d of 90 acked, %zu reports, retries %u, crc errors %u, flips %llu, drops %llu\n", acked,
              reported.size(), client.counters().link.retries, client.counters().link.crc_errors,
              static_cast<unsigned long long>(stats.to_mcu.bits_flipped + stats.from_mcu.bits_flipped),
              static_cast<unsigned long long>(stats.to_mcu.bytes_dropped + stats.from_mcu.bytes_dropped));
  EXPECT_GT(acked, 60);
  EXPECT_GT(client.counters().link.retries, 0u);
  if (last_acked_position > 0) {
    EXPECT_TRUE(wait_for([&] {
      return std::abs(servo_pulse_us(uno) - (1000.0 + last_acked_position * 1000.0 / 180.0)) < 6.0;
    })) << servo_pulse_us(uno);
  }
  client.close();
}

TEST(ProxyInterop, CompatModeDrivesTheDeployedFirmware) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), board("proxy-compat.elf", Pacing::real_time));
  auto& uno = stream->board();
  EventLog log;
  ProxyClient client(stream, ProxyOptions::compat(), log.handler());
  // Like the deployed host: command the device once it announced the end of its setup (it re-sends
  // nothing after that, but a client re-sends its inits on a RESET announcement).
  ASSERT_TRUE(wait_for([&] {
    for (const auto& event : log.all<events::CompatEvent>()) {
      if (event.type == RocketryProto::RESET) return true;
    }
    return false;
  }));
  client.servo(9).init(90);
  client.digital(13).init(false);
  client.servo(9).set(180);
  client.digital(13).set(true);
  EXPECT_TRUE(wait_for([&] { return std::abs(servo_pulse_us(uno) - 2000.0) < 5.0; })) << servo_pulse_us(uno);
  EXPECT_TRUE(wait_for([&] { return uno.digital_level(13); }));
  // The deployed device streams its pin states; and a control of an uninitialised pin is an error.
  EXPECT_TRUE(wait_for([&] {
    const auto state = client.pin_state(PinKind::digital, 13);
    return state && state->has_value && state->value == 1;
  }));
  client.digital(7).set(true);
  EXPECT_TRUE(wait_for([&] {
    for (const auto& error : log.all<events::CompatError>()) {
      if (error.type == RocketryProto::PIN_NOT_INITIALIZED && error.data == 7) return true;
    }
    return false;
  }));
  client.close();
}

}  // namespace
}  // namespace tether::proxy
