// Host tests of ProxyDevice (primary mode): the wire behaviour documented in proxy_device.hpp, driven
// byte by byte with nanopb-encoded, CRC-framed ArduinoIn messages and a fake clock.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "fake_hardware.hpp"
#include "tether/core/crc.hpp"
#include "tether/proxy/device/proxy_device.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether_proxy.pb.h"
#include "wire.hpp"

namespace {

using namespace tether::proxy::device;
using tether::Millis;
using tether::proxy::Integrity;
using In = tether_proxy_ArduinoIn;
using Out = tether_proxy_ArduinoOut;

In message(uint32_t id, pb_size_t which) {
  In in = tether_proxy_ArduinoIn_init_zero;
  in.messageId = id;
  in.which_data = which;
  return in;
}
In ping(uint32_t id) { return message(id, tether_proxy_ArduinoIn_ping_tag); }
In servo_init(uint32_t id, uint32_t pin, int32_t safe) {
  In in = message(id, tether_proxy_ArduinoIn_servoInit_tag);
  in.data.servoInit.pin = pin;
  in.data.servoInit.safePosition = safe;
  return in;
}
In servo_control(uint32_t id, uint32_t pin, int32_t position) {
  In in = message(id, tether_proxy_ArduinoIn_servoControl_tag);
  in.data.servoControl.pin = pin;
  in.data.servoControl.position = position;
  return in;
}
In digital_init(uint32_t id, uint32_t pin, bool safe) {
  In in = message(id, tether_proxy_ArduinoIn_digitalInit_tag);
  in.data.digitalInit.pin = pin;
  in.data.digitalInit.safeState = safe;
  return in;
}
In digital_control(uint32_t id, uint32_t pin, bool state) {
  In in = message(id, tether_proxy_ArduinoIn_digitalControl_tag);
  in.data.digitalControl.pin = pin;
  in.data.digitalControl.state = state;
  return in;
}

// What the tests compare: one line per ArduinoOut.
std::string describe(const Out& out) {
  switch (out.which_data) {
    case tether_proxy_ArduinoOut_ack_tag:
      return "ack " + std::to_string(out.data.ack.messageId) + (out.data.ack.refused ? " refused" : "");
    case tether_proxy_ArduinoOut_error_tag:
      return std::string(out.data.error.level == tether_proxy_Error_Level_WARNING ? "warning " : "fatal ") +
             out.data.error.text;
    case tether_proxy_ArduinoOut_info_tag:
      return "info " + std::to_string(out.data.info.sessionId) + (out.data.info.pingFailsafeTriggered ? " failsafe" : "");
    case tether_proxy_ArduinoOut_resetEvent_tag:
      return "reset " + std::to_string(out.data.resetEvent.sessionId);
    case tether_proxy_ArduinoOut_pinState_tag:
      return "pin " + std::to_string(out.data.pinState.pin) + " = " + std::to_string(out.data.pinState.value) +
             (out.data.pinState.failsafe ? " failsafe" : "");
    default:
      return "?";
  }
}

using Lines = std::vector<std::string>;

class ProxyDeviceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    device.begin(kSession, 0);
  }
  // Sends `in` framed with its CRC, byte by byte, at `now`.
  void send(const In& in, Millis now = 0) { feed(wire::frame(encode(in), Integrity::crc16), now); }
  static wire::Bytes encode(const In& in) { return wire::encode(tether_proxy_ArduinoIn_fields, &in); }
  void feed(const wire::Bytes& bytes, Millis now = 0) {
    for (const uint8_t byte : bytes) device.handle_byte(byte, now);
  }
  // Everything the device sent since the last call, one line per message.
  Lines take() {
    Lines lines;
    for (const Out& out : wire::decode_all<Out>(recorder.bytes, Integrity::crc16, tether_proxy_ArduinoOut_fields)) {
      lines.push_back(describe(out));
    }
    recorder.clear();
    return lines;
  }
  // Polls every millisecond from `from` to `to` inclusive.
  void run(Millis from, Millis to) {
    for (Millis now = from; now <= to; ++now) device.poll(now);
  }

  static constexpr uint32_t kSession = 0xC0FFEE;
  wire::Recorder recorder;
  OutputTable outputs;
  ProxyDevice device{outputs, recorder.sink(), &wire::Recorder::restart, &recorder};
  fake::Hardware& hw = fake::hardware();
};

TEST_F(ProxyDeviceTest, BootSendsResetEventAfterALeadingDelimiter) {
  ASSERT_FALSE(recorder.bytes.empty());
  EXPECT_EQ(recorder.bytes.front(), 0x00);
  EXPECT_EQ(take(), (Lines{"reset 12648430"}));
  EXPECT_EQ(device.session_id(), kSession);
}

TEST_F(ProxyDeviceTest, FramesAreCobsCrcProtobuf) {
  take();
  send(ping(1));
  // Ack{1} = 0a 02 08 01; its CRC-16/MCRF4XX in front, little-endian; COBS; 00. No leading delimiter.
  const wire::Bytes payload = {0x0a, 0x02, 0x08, 0x01};
  EXPECT_EQ(recorder.bytes, wire::frame(payload, Integrity::crc16));
}

TEST_F(ProxyDeviceTest, EveryMessageIsAckedAfterWhatItCauses) {
  take();
  send(servo_init(1, 9, 90));
  EXPECT_EQ(take(), (Lines{"pin 9 = 90", "ack 1"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 1500);
  send(servo_control(2, 9, 0));
  EXPECT_EQ(take(), (Lines{"pin 9 = 0", "ack 2"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 1000);
  send(servo_control(3, 9, 180));
  EXPECT_EQ(take(), (Lines{"pin 9 = 180", "ack 3"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 2000);
  send(servo_control(4, 9, 999));  // out of range: acked as refused, the servo stays
  EXPECT_EQ(take(), (Lines{"warning pin 9: position 999 not in 0..180", "ack 4 refused"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 2000);
  send(servo_control(40, 9, -5));
  EXPECT_EQ(take(), (Lines{"warning pin 9: position -5 not in 0..180", "ack 40 refused"}));
  send(servo_init(41, 10, 200));
  EXPECT_EQ(take(), (Lines{"warning pin 10: position 200 not in 0..180", "ack 41 refused"}));
  send(digital_init(5, 13, false));
  EXPECT_EQ(take(), (Lines{"pin 13 = 0", "ack 5"}));
  send(digital_control(6, 13, true));
  EXPECT_EQ(take(), (Lines{"pin 13 = 1", "ack 6"}));
  EXPECT_TRUE(hw.pins[13].level);
  send(ping(7));
  EXPECT_EQ(take(), (Lines{"ack 7"}));
  send(message(8, tether_proxy_ArduinoIn_pingFailsafeReset_tag));
  EXPECT_EQ(take(), (Lines{"ack 8"}));
  EXPECT_EQ(device.counters().executed, 10u);
  EXPECT_EQ(device.counters().refused, 3u);  // the out-of-range positions
}

TEST_F(ProxyDeviceTest, ARepeatedMessageIsAckedButNotExecutedAgain) {
  send(servo_init(1, 9, 90));
  send(servo_control(2, 9, 180));
  send(servo_control(3, 9, 0));
  take();
  hw.calls.clear();
  send(servo_control(2, 9, 180));  // a re-send of 2 (its ack was lost): the servo must stay at 0
  EXPECT_EQ(take(), (Lines{"ack 2"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 1000);
  EXPECT_TRUE(hw.calls.empty());
  send(servo_control(2, 9, 180));
  send(servo_control(2, 9, 180));
  EXPECT_EQ(take(), (Lines{"ack 2", "ack 2"}));
  EXPECT_EQ(device.counters().link.duplicates, 3u);
  EXPECT_EQ(device.counters().executed, 3u);
}

TEST_F(ProxyDeviceTest, RepeatedPingDoesNotFeedTheFailsafe) {
  send(ping(1), 1000);
  send(ping(1), 9000);  // the same ping again: acked, not a heartbeat
  take();
  run(1, 10999);
  EXPECT_EQ(take(), (Lines{"info 12648430", "info 12648430"}));
  device.poll(11000);  // 10 s after the first (and only) heartbeat
  EXPECT_EQ(take(), (Lines{"warning ping failsafe"}));
}

TEST_F(ProxyDeviceTest, TheSameIdWithOtherBytesIsANewMessage) {
  send(digital_init(1, 13, false));
  send(digital_control(7, 13, true));
  take();
  send(digital_control(7, 13, false));  // a new host session restarting its ids: different bytes
  EXPECT_EQ(take(), (Lines{"pin 13 = 0", "ack 7"}));
  EXPECT_FALSE(hw.pins[13].level);
}

TEST_F(ProxyDeviceTest, RemembersTheLastEightMessages) {
  send(digital_init(100, 13, false));
  for (uint32_t id = 1; id <= 7; ++id) send(ping(id));
  take();
  send(digital_init(100, 13, false));  // 8 messages back: still known
  EXPECT_EQ(take(), (Lines{"ack 100"}));
  send(ping(8));
  send(digital_init(100, 13, false));  // 9 back: forgotten, executed again
  EXPECT_EQ(take(), (Lines{"ack 8", "pin 13 = 0", "ack 100"}));
}

TEST_F(ProxyDeviceTest, RefusalsAreWarningsNamingThePin) {
  take();
  send(servo_init(1, 5, 90));
  send(servo_init(2, 1823, 1231));
  send(digital_init(3, 1, true));
  send(digital_control(4, 13, true));
  send(servo_control(5, 9, 10));
  send(digital_init(6, 10, false));
  send(servo_control(7, 10, 10));
  send(servo_init(8, 9, 0));
  send(digital_control(9, 9, true));
  send(digital_init(10, 20, true));
  EXPECT_EQ(take(), (Lines{"warning servo on pin 5: D9/D10 only", "ack 1 refused",
                           "warning pin 1823 does not exist", "ack 2 refused",
                           "warning pin 1 is the UART", "ack 3 refused",
                           "warning pin 13 not initialised", "ack 4 refused",
                           "warning pin 9 not initialised", "ack 5 refused",
                           "pin 10 = 0", "ack 6",
                           "warning pin 10 is not a servo", "ack 7 refused",
                           "pin 9 = 0", "ack 8",
                           "warning pin 9 is not digital", "ack 9 refused",
                           "warning pin 20 does not exist", "ack 10 refused"}));
  EXPECT_EQ(device.counters().refused, 8u);
  EXPECT_FALSE(hw.pins[5].output);
}

TEST_F(ProxyDeviceTest, UnknownMessage) {
  take();
  send(message(42, 0));  // only a messageId (or a oneof case this device does not know)
  EXPECT_EQ(take(), (Lines{"warning unknown message", "ack 42 refused"}));
}

// a rebooted device got re-sends of controls before the host saw its ResetEvent and replayed the
// inits; it acked them without running them and the caller was told they took effect. The ack says so now,
// and a refused message is not remembered: its re-send after the init runs.
TEST_F(ProxyDeviceTest, AControlOfAnUninitialisedPinIsAckedAsRefusedAndItsResendRunsOnceInitialised) {
  take();
  send(servo_control(5, 9, 40));
  EXPECT_EQ(take(), (Lines{"warning pin 9 not initialised", "ack 5 refused"}));
  send(servo_init(6, 9, 90));
  send(servo_control(5, 9, 40));  // the same message again: not a duplicate, it never ran
  send(servo_control(5, 9, 40));  // now it is
  EXPECT_EQ(take(), (Lines{"pin 9 = 90", "ack 6", "pin 9 = 40", "ack 5", "ack 5"}));
}

TEST_F(ProxyDeviceTest, UndecodablePayloadIsReportedNotAcked) {
  take();
  feed(wire::frame({0x0a, 0x05, 0x08}, Integrity::crc16));  // a submessage running past the end
  EXPECT_EQ(take(), (Lines{"warning decode error"}));
  feed(wire::frame({0xff, 0xff, 0xff}, Integrity::crc16));
  EXPECT_EQ(take(), (Lines{"warning decode error"}));
  EXPECT_EQ(device.counters().decode_errors, 2u);
}

TEST_F(ProxyDeviceTest, InfoEveryFiveSeconds) {
  take();
  run(1, 4999);
  EXPECT_TRUE(take().empty());
  device.poll(5000);
  EXPECT_EQ(take(), (Lines{"info 12648430"}));
  send(ping(1), 5000);
  take();
  run(5001, 9999);
  EXPECT_TRUE(take().empty());
  device.poll(10000);
  EXPECT_EQ(take(), (Lines{"info 12648430"}));
  device.poll(31000);  // a loop that stalled: one info, then back on a 5 s period from now
  EXPECT_EQ(take(), (Lines{"warning ping failsafe", "info 12648430 failsafe"}));
  run(31001, 35999);
  EXPECT_TRUE(take().empty());
  device.poll(36000);
  EXPECT_EQ(take(), (Lines{"info 12648430 failsafe"}));
}

TEST_F(ProxyDeviceTest, FailsafeAfterTenSecondsWithoutPing) {
  send(servo_init(1, 9, 90), 0);
  send(servo_init(2, 10, 30), 0);
  send(digital_init(3, 13, false), 0);
  send(digital_init(4, 7, true), 0);
  send(servo_control(5, 9, 180), 100);
  send(servo_control(6, 10, 0), 100);
  send(digital_control(7, 13, true), 100);
  send(digital_control(8, 7, false), 100);
  for (Millis t = 1000; t < 10000; t += 1000) send(digital_control(100 + t, 13, true), t);  // not pings
  take();
  run(1, 9999);
  EXPECT_EQ(take(), (Lines{"info 12648430"}));
  EXPECT_FALSE(device.failsafe_triggered());
  EXPECT_EQ(hw.pins[9].pulse_us, 2000);
  device.poll(10000);  // exactly 10 s after boot: failsafe first, then the info that shows it
  EXPECT_EQ(take(), (Lines{"warning ping failsafe", "pin 7 = 1 failsafe", "pin 9 = 90 failsafe",
                           "pin 10 = 30 failsafe", "pin 13 = 0 failsafe", "info 12648430 failsafe"}));
  EXPECT_TRUE(device.failsafe_triggered());
  EXPECT_EQ(hw.pins[9].pulse_us, 1500);
  EXPECT_EQ(hw.pins[10].pulse_us, 1166);
  EXPECT_FALSE(hw.pins[13].level);
  EXPECT_TRUE(hw.pins[7].level);
  EXPECT_EQ(device.counters().link.failsafes, 1u);
  run(10001, 14999);  // once per silence
  EXPECT_TRUE(take().empty());
}

TEST_F(ProxyDeviceTest, PingsKeepTheFailsafeAwayAndTheFlagIsSticky) {
  send(digital_init(1, 13, true));
  send(digital_control(2, 13, false));
  for (Millis t = 1000; t <= 20000; t += 1000) {
    run(t - 999, t);
    send(ping(t), t);
  }
  take();
  EXPECT_FALSE(device.failsafe_triggered());
  run(20001, 29999);
  EXPECT_FALSE(device.failsafe_triggered());
  device.poll(30000);  // 10 s after the last ping
  EXPECT_TRUE(device.failsafe_triggered());
  EXPECT_EQ(take(), (Lines{"info 12648430", "warning ping failsafe", "pin 13 = 1 failsafe", "info 12648430 failsafe"}));
  send(ping(50), 30001);  // the host is back: the flag stays until PingFailsafeReset
  send(digital_control(51, 13, false), 30001);  // controls are executed after a failsafe
  EXPECT_EQ(take(), (Lines{"ack 50", "pin 13 = 0", "ack 51"}));
  device.poll(35000);
  EXPECT_EQ(take(), (Lines{"info 12648430 failsafe"}));
  send(message(52, tether_proxy_ArduinoIn_pingFailsafeReset_tag), 35001);
  EXPECT_FALSE(device.failsafe_triggered());
  device.poll(40000);
  EXPECT_EQ(take(), (Lines{"ack 52", "info 12648430"}));
  run(40001, 40001 + 10000);  // a new silence: a second failsafe
  EXPECT_TRUE(device.failsafe_triggered());
  EXPECT_EQ(device.counters().link.failsafes, 2u);
}

TEST_F(ProxyDeviceTest, ResetIsAckedThenRestarts) {
  take();
  send(message(9, tether_proxy_ArduinoIn_reset_tag));
  EXPECT_EQ(recorder.restarts, 1);
  EXPECT_EQ(recorder.bytes_at_restart, recorder.bytes.size());  // the ack was out before the restart
  EXPECT_EQ(take(), (Lines{"ack 9"}));
}

TEST_F(ProxyDeviceTest, DropsAreCountedAndReportedWithTheInfo) {
  take();
  const wire::Bytes payload = encode(ping(1));
  const uint16_t crc = tether::Crc16Mcrf4xx::compute(tether::ByteView(payload.data(), payload.size()));
  wire::Bytes raw(2 + payload.size());
  raw[0] = static_cast<uint8_t>((crc & 0xFF) ^ 0x01);  // a wrong CRC
  raw[1] = static_cast<uint8_t>(crc >> 8);
  std::copy(payload.begin(), payload.end(), raw.begin() + 2);
  // Different counts per cause: the report shows each counter under its own label.
  for (int i = 0; i < 3; ++i) feed(wire::frame(raw, Integrity::none));  // COBS(bad crc ‖ payload) ‖ 00
  feed({0x05, 0x01, 0x00});  // bad COBS: the code runs past the delimiter
  wire::Bytes big(80, 0x11);
  for (int i = 0; i < 2; ++i) feed(wire::frame(big, Integrity::crc16));  // over 64 bytes of payload
  const wire::Bytes stalled = wire::frame(encode(ping(1)), Integrity::crc16);
  for (Millis i = 0; i < 4; ++i) {  // half a frame, then silence past the partial-frame deadline
    feed(wire::Bytes(stalled.begin(), stalled.begin() + 3), 1000 + 200 * i);
    device.poll(1100 + 200 * i);
  }
  EXPECT_TRUE(take().empty());  // nothing per frame
  EXPECT_EQ(device.counters().link.crc_errors, 3u);
  EXPECT_EQ(device.counters().link.framing_errors, 1u);
  EXPECT_EQ(device.counters().link.oversize_frames, 2u);
  device.poll(5000);
  EXPECT_EQ(take(), (Lines{"info 12648430", "warning dropped: crc 3 cobs 1 long 2 stall 4"}));
  send(ping(2), 5001);
  device.poll(10000);  // nothing new dropped: no report
  EXPECT_EQ(take(), (Lines{"ack 2", "info 12648430"}));
}

TEST_F(ProxyDeviceTest, AStalledFrameIsDroppedAndTheNextOneStillArrives) {
  take();
  const wire::Bytes first = wire::frame(encode(ping(1)), Integrity::crc16);
  feed(wire::Bytes(first.begin(), first.begin() + 3), 1000);  // half a frame, then silence
  run(1001, 1099);
  EXPECT_EQ(device.counters().link.partial_timeouts, 0u);
  device.poll(1100);
  EXPECT_EQ(device.counters().link.partial_timeouts, 1u);
  send(ping(2), 1200);  // no leading 0x00: still decoded
  EXPECT_EQ(take(), (Lines{"ack 2"}));
}

TEST_F(ProxyDeviceTest, LeadingDelimitersAndEmptyFramesAreIgnored) {
  take();
  feed({0x00, 0x00});
  feed(wire::frame(encode(ping(3)), Integrity::crc16, true));
  EXPECT_EQ(take(), (Lines{"ack 3"}));
  EXPECT_EQ(device.counters().link.framing_errors, 0u);
}

}  // namespace

TEST(ProxyDeviceRuns, HandlingRunsOfBytesIsHandlingThemOneByOne) {
  // The image hands the device what its UART ring holds (handle_bytes); it must answer, count and time
  // out partial frames exactly as byte-by-byte feeding does, whatever the runs' lengths.
  auto random = tether::testing::seeded_generator(17);
  for (int round = 0; round < 60; ++round) {
    wire::Bytes stream;
    for (uint32_t id = 1; id <= 10; ++id) {
      In in = random() % 2 == 0 ? servo_init(id, 9 + static_cast<uint32_t>(random() % 2), static_cast<int32_t>(random() % 200))
                                : digital_control(id, static_cast<uint32_t>(random() % 22), random() % 2 == 0);
      if (random() % 5 == 0) in = ping(id - 1);  // an id already seen: a re-send, or a new message
      wire::Bytes frame = wire::frame(wire::encode(tether_proxy_ArduinoIn_fields, &in), Integrity::crc16);
      const unsigned damage = static_cast<unsigned>(random() % 6);
      if (damage == 0) frame[random() % (frame.size() - 1)] ^= static_cast<uint8_t>(1 + random() % 255);
      if (damage == 1) frame.resize(random() % frame.size());  // cut short: the next frame follows at once
      if (damage == 2) frame.insert(frame.begin(), static_cast<uint8_t>(random()));  // line noise before it
      stream.insert(stream.end(), frame.begin(), frame.end());
    }
    // Time passes between some bytes: a frame cut short may stall past the partial-frame deadline.
    std::vector<Millis> at(stream.size());
    Millis now = 0;
    for (Millis& t : at) {
      if (random() % 16 == 0) now += static_cast<Millis>(random() % 150);
      t = now;
    }
    fake::reset();
    wire::Recorder by_byte_out;
    OutputTable by_byte_outputs;
    ProxyDevice by_byte{by_byte_outputs, by_byte_out.sink()};
    by_byte.begin(1, 0);
    for (size_t i = 0; i < stream.size(); ++i) {
      by_byte.poll(at[i]);
      by_byte.handle_byte(stream[i], at[i]);
    }
    fake::reset();
    wire::Recorder by_run_out;
    OutputTable by_run_outputs;
    ProxyDevice by_run{by_run_outputs, by_run_out.sink()};
    by_run.begin(1, 0);
    size_t i = 0;
    while (i < stream.size()) {
      // A run never spans a change of time: the image reads the clock once per run.
      size_t end = i + 1 + static_cast<size_t>(random() % 40);
      if (end > stream.size()) end = stream.size();
      for (size_t j = i + 1; j < end; ++j) {
        if (at[j] != at[i]) end = j;
      }
      by_run.poll(at[i]);
      while (i < end) {
        const size_t used = by_run.handle_bytes(tether::ByteView(stream.data() + i, end - i), at[i]);
        ASSERT_GE(used, 1u);
        ASSERT_LE(used, end - i);
        i += used;
      }
    }
    ASSERT_EQ(by_run_out.bytes, by_byte_out.bytes) << "round " << round;
    const tether::LinkCounters& a = by_run.counters().link;
    const tether::LinkCounters& b = by_byte.counters().link;
    EXPECT_EQ(a.frames_ok, b.frames_ok);
    EXPECT_EQ(a.crc_errors, b.crc_errors);
    EXPECT_EQ(a.framing_errors, b.framing_errors);
    EXPECT_EQ(a.oversize_frames, b.oversize_frames);
    EXPECT_EQ(a.partial_timeouts, b.partial_timeouts);
    EXPECT_EQ(a.duplicates, b.duplicates);
    EXPECT_EQ(by_run.counters().executed, by_byte.counters().executed);
  }
}
