// Client in compatibility mode (the deployed variant): the spec's vectors byte for byte in both
// directions, events, the init replay on EventMessage{RESET}, the 5 s staleness rule (shortened), close.
#include <gtest/gtest.h>

#include <boost/asio/use_future.hpp>

#include <thread>

#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "test_support.hpp"

namespace tether::proxy::testing {
namespace {

namespace asio = boost::asio;
using IoThread = transports::IoThread;

FakeDevice::Script silent() {
  return [](const DeviceFrame&, FakeDevice&) {};
}

TEST(ProxyCompat, HostVectorsByteForByte) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  EXPECT_EQ(link.client->mode(), Mode::compat);
  const SendResult init = link.client->servo(1823).init(1231);
  EXPECT_FALSE(init.acked);  // no acks in the deployed variant: complete when written
  EXPECT_EQ(init.attempts, 1);
  EXPECT_EQ(init.message_id, 0u);
  link.client->servo(5).set(180);
  link.client->digital(13).set(true);
  RocketryProto::ArduinoIn reset;
  reset.mutable_reset();
  link.client->send(reset);
  const std::string expected = unhex(
      "00 09 0a 06 08 9f 0e 10 cf 09 00"   // ServoInit{1823, 1231}
      "00 08 12 05 08 05 10 b4 01 00"      // ServoControl{5, 180}
      "00 07 22 04 08 0d 10 01 00"         // DigitalControl{13, true}
      "00 02 2a 01 00");                   // Reset{}
  ASSERT_TRUE(eventually([&] { return link.device->received().size() >= expected.size(); }));
  EXPECT_EQ(hex(link.device->received()), hex(expected));
  const auto frames = link.device->frames();
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_TRUE(frames[0].compat.has_servoinit());
  EXPECT_TRUE(frames[3].compat.has_reset());
  EXPECT_EQ(link.client->counters().pings_sent, 0u);  // no ping, no handshake
  EXPECT_TRUE(link.client->session().established);
  EXPECT_FALSE(link.client->session().session_id.has_value());
}

TEST(ProxyCompat, DigitalInitAndAnyRocketryMessage) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  link.client->digital(7).init(true);
  RocketryProto::ArduinoIn motor;
  motor.mutable_dcmotorcontrol()->set_pinforward(3);
  motor.mutable_dcmotorcontrol()->set_position(-5);
  std::future<SendResult> sent = link.client->async_send(motor, asio::use_future);
  EXPECT_NO_THROW(sent.get());
  ASSERT_TRUE(link.device->wait_for([](const auto& frames) { return frames.size() == 2; }, kPrompt));
  const auto frames = link.device->frames();
  EXPECT_EQ(frames[0].compat.digitalinit().pin(), 7u);
  EXPECT_EQ(frames[0].compat.digitalinit().safestate(), 1u);
  EXPECT_EQ(frames[1].compat.dcmotorcontrol().position(), -5);
}

TEST(ProxyCompat, DeviceVectorsBecomeEvents) {
  IoThread io;
  Options options = compat_test_options();
  options.compat_replay_on_reset = false;
  Link link(io.executor(), options, silent());
  link.device->send(unhex("02 0a 01 00"));              // EventMessage{RESET}
  link.device->send(unhex("07 12 04 08 02 10 0d 00"));  // ErrorMessage{PIN_NOT_INITIALIZED, 13}
  link.device->send(unhex("05 22 02 08 08 00"));        // DigitalState{8, false}
  ASSERT_TRUE(link.log.wait_for<events::PinReport>(1));
  const auto compat_events = link.log.of<events::CompatEvent>();
  ASSERT_EQ(compat_events.size(), 1u);
  EXPECT_EQ(compat_events[0].type, RocketryProto::RESET);
  EXPECT_EQ(compat_events[0].data, 0);
  const auto errors = link.log.of<events::CompatError>();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].type, RocketryProto::PIN_NOT_INITIALIZED);
  EXPECT_EQ(errors[0].data, 13);
  const auto reports = link.log.of<events::PinReport>();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].kind, PinKind::digital);
  EXPECT_EQ(reports[0].pin, 8u);
  EXPECT_EQ(reports[0].value, 0);
  EXPECT_EQ(link.client->counters().link.frames_ok, 3u);
  EXPECT_EQ(link.client->counters().link.crc_errors, 0u);
  const auto state = link.client->digital(8).state();
  ASSERT_TRUE(state.has_value());
  EXPECT_TRUE(state->has_value);
  EXPECT_FALSE(state->stale);
}

TEST(ProxyCompat, RepeatedStatesAreReportedOnlyWhenTheyChange) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  RocketryProto::ArduinoOut out;
  out.mutable_servostate()->set_pin(5);
  out.mutable_servostate()->set_position(90);
  const std::string ninety = FakeDevice::frame_bytes(out.SerializeAsString(), Integrity::none);
  out.mutable_servostate()->set_position(91);
  const std::string ninety_one = FakeDevice::frame_bytes(out.SerializeAsString(), Integrity::none);
  for (int i = 0; i < 5; ++i) link.device->send(ninety);
  link.device->send(ninety_one);
  ASSERT_TRUE(link.log.wait_for<events::PinReport>(2));
  ASSERT_TRUE(eventually([&] { return link.client->counters().link.frames_ok == 6; }));
  const auto reports = link.log.of<events::PinReport>();
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].kind, PinKind::servo);
  EXPECT_EQ(reports[0].value, 90);
  EXPECT_EQ(reports[1].value, 91);
}

TEST(ProxyCompat, ResetEventReplaysTheInitsInOrder) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  link.client->servo(1823).init(1231);
  link.client->digital(7).init(true);
  link.client->servo(5).set(180);  // not an init: not replayed
  const std::string before = link.device->received();
  link.device->send(unhex("02 0a 01 00"));  // the device (re)booted
  ASSERT_TRUE(link.log.wait_for<events::CompatEvent>(1));
  ASSERT_TRUE(eventually([&] { return link.device->frames().size() == 5; }));
  const std::string replay = link.device->received().substr(before.size());
  EXPECT_EQ(hex(replay), "00 09 0a 06 08 9f 0e 10 cf 09 00 00 07 1a 04 08 07 10 01 00");
  EXPECT_EQ(link.client->counters().inits_replayed, 2u);
}

TEST(ProxyCompat, StalenessRuleReportsSilentPins) {
  IoThread io;
  Options options = compat_test_options();
  options.timing.stale_after = 200;
  Link link(io.executor(), options, silent());
  client::testing::ManualClock& clock = *link.clock;
  const Millis start = clock.now();
  link.client->digital(8).init(false);
  link.client->servo(3).init(0);  // never reports
  // The device sends DigitalState{8, true} every 20 ms (simulated) from 0 to 380 ms, then stops.
  RocketryProto::ArduinoOut out;
  out.mutable_digitalstate()->set_pin(8);
  out.mutable_digitalstate()->set_activated(true);
  const std::string state = FakeDevice::frame_bytes(out.SerializeAsString(), Integrity::none);
  for (std::uint32_t i = 0; i < 20; ++i) {
    if (i > 0) clock.advance(20);
    link.device->send(state);
    ASSERT_TRUE(eventually([&] { return link.client->counters().link.frames_ok == i + 1; }));
    // The servo is lost exactly 200 ms after its init, and not before.
    EXPECT_EQ(link.log.of<events::PinLost>().size(), i >= 10 ? 1u : 0u) << "at " << 20 * i << " ms";
  }
  auto lost = link.log.of<events::PinLost>();
  ASSERT_EQ(lost.size(), 1u);
  EXPECT_EQ(lost[0].kind, PinKind::servo);
  EXPECT_EQ(lost[0].pin, 3u);
  EXPECT_EQ(lost[0].silent_ms, 200u);
  const auto servo = link.client->servo(3).state();
  ASSERT_TRUE(servo.has_value());
  EXPECT_TRUE(servo->stale);
  EXPECT_FALSE(servo->has_value);
  // The digital pin was refreshed all along; it goes stale 200 ms after the last state (sent at 380 ms).
  Millis due = 0;
  ASSERT_TRUE(clock.wait_for_due(static_cast<Millis>(start + 380 + 200), due)) << "+" << due - start;
  clock.advance_to(due);
  ASSERT_TRUE(link.log.wait_for<events::PinLost>(2));
  lost = link.log.of<events::PinLost>();
  EXPECT_EQ(lost[1].kind, PinKind::digital);
  EXPECT_EQ(lost[1].pin, 8u);
  EXPECT_EQ(lost[1].silent_ms, 200u);
  EXPECT_TRUE(link.client->digital(8).state()->stale);
  EXPECT_EQ(link.log.of<events::PinReport>().size(), 1u);  // the first state only: the rest repeated it
  EXPECT_EQ(link.client->counters().pins_lost, 2u);
  // It comes back: reported again, no longer stale, and lost again only after another silence.
  link.device->send(state);
  ASSERT_TRUE(link.log.wait_for<events::PinReport>(2));
  EXPECT_FALSE(link.client->digital(8).state()->stale);
  EXPECT_EQ(link.log.of<events::PinReport>()[1].value, 1);
  ASSERT_TRUE(clock.wait_for_due(static_cast<Millis>(start + 580 + 200), due)) << "+" << due - start;
  clock.advance_to(due);
  ASSERT_TRUE(link.log.wait_for<events::PinLost>(3));
  EXPECT_EQ(link.log.of<events::PinLost>().size(), 3u);  // the silent servo is not reported twice
}

TEST(ProxyCompat, StalenessDefaultsToFiveSeconds) {
  EXPECT_EQ(Options::compat().timing.stale_after, 5000u);
  EXPECT_EQ(Options::compat().timing.baud, 57600u);
}

TEST(ProxyCompat, UndecodableAndUnknownFramesAreCounted) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  link.device->send(unhex("03 ff ff 00"));  // not protobuf
  link.device->send(unhex("03 78 01 00"));  // field 15: unknown to RocketryProto
  link.device->send(unhex("05 12 11 00"));  // bad COBS
  ASSERT_TRUE(link.log.wait_for<events::UndecodableMessage>(2));
  ASSERT_TRUE(eventually([&] { return link.client->counters().link.framing_errors == 1; }));
  EXPECT_EQ(link.client->counters().undecodable, 1u);
  EXPECT_EQ(link.client->counters().unknown_messages, 1u);
}

TEST(ProxyCompat, PrimaryOnlyOperationsAreRejected) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  error_code error;
  ArduinoIn primary;
  primary.mutable_ping();
  link.client->send(primary, error);
  EXPECT_EQ(error, ProxyError::wrong_mode);
  EXPECT_THROW(link.client->reset_failsafe(), boost::system::system_error);
  link.client->send(RocketryProto::ArduinoIn(), error);
  EXPECT_EQ(error, ProxyError::invalid_message);
  // A valid message after them completes when written: it is the first and only frame on the wire.
  link.client->digital(13).set(true);
  ASSERT_TRUE(link.device->wait_for([](const auto& frames) { return frames.size() == 1; }, kPrompt));
  EXPECT_EQ(hex(link.device->received()), "00 07 22 04 08 0d 10 01 00");  // DigitalControl{13, true}
}

TEST(ProxyCompat, RestartSessionWritesReset) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  link.client->restart_session();
  ASSERT_TRUE(eventually([&] { return link.device->received().size() == 5; }));
  EXPECT_EQ(hex(link.device->received()), "00 02 2a 01 00");
}

TEST(ProxyCompat, CloseFailsLaterSendsAndNeverHangs) {
  IoThread io;
  Link link(io.executor(), compat_test_options(), silent());
  Completions done;
  for (std::size_t i = 0; i < 50; ++i) link.client->servo(5).async_set(static_cast<std::int32_t>(i), done.handler(i));
  link.client->close();
  ASSERT_TRUE(done.wait_for(50));  // written before the close, or aborted: each exactly once
  for (std::size_t i = 0; i < 50; ++i) {
    const error_code error = done.at(i).error;
    EXPECT_TRUE(!error || error == asio::error::operation_aborted) << i << " " << error.message();
  }
  error_code error;
  link.client->servo(5).set(1, error);
  EXPECT_EQ(error, asio::error::operation_aborted);
}

// A device that stopped reading: the stream takes a few bytes and then none. Every send, the one whose
// frame is half written included, fails with `timed_out` at its `send_budget` instead of waiting forever.
TEST(ProxyCompat, SendsToADeviceThatStoppedReadingTimeOutAtTheirBudget) {
  IoThread io;
  Options options = compat_test_options();
  options.timing.send_budget = 300;
  auto clock = client::testing::ManualClock::create();
  options.clock = clock;
  // Nobody reads the other end; it holds 4 bytes, less than one frame.
  auto [host_end, device_end] = transports::InMemoryStream::make_pair(io.executor(), 4);
  EventLog log;
  Client client(host_end, options, log.handler());
  constexpr std::size_t kSends = 3;
  Completions done;
  const Millis start = clock->now();
  for (std::size_t i = 0; i < kSends; ++i) {
    client.servo(5).async_set(static_cast<std::int32_t>(10 * i), done.handler(i));
  }
  Millis due = 0;
  ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(start + 300), due, kPrompt)) << "+" << due - start;
  EXPECT_EQ(done.calls(), 0u);
  clock->advance_to(static_cast<Millis>(start + 300));
  // The sends are posted: one the client took after that advance has its budget from then. The clock moves
  // on to each such deadline (never past start + 600) until every send ended.
  const auto give_up = std::chrono::steady_clock::now() + kPrompt;
  while (done.calls() < kSends && std::chrono::steady_clock::now() < give_up) {
    Millis next = 0;
    if (clock->next_due(next) && next <= static_cast<Millis>(start + 600)) clock->advance_to(next);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(done.wait_for(kSends)) << done.calls() << " of " << kSends << " sends completed";
  for (std::size_t i = 0; i < kSends; ++i) EXPECT_EQ(done.at(i).error, ProxyError::timed_out) << "send " << i;
  // The blocking form ends the same way.
  std::thread advance([&] {
    Millis seen = 0;
    if (clock->wait_for_due(static_cast<Millis>(clock->now() + 300), seen, kPrompt)) clock->advance(300);
  });
  error_code error;
  client.servo(5).set(7, error);
  advance.join();
  EXPECT_EQ(error, ProxyError::timed_out);
  client.close();
  device_end->close();
}

}  // namespace
}  // namespace tether::proxy::testing
