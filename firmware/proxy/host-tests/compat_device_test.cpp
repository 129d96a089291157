// Host tests of CompatDevice (the deployed variant): the spec's vectors byte for byte, and the behaviour
// documented in compat_device.hpp.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "fake_hardware.hpp"
#include "rocketry.pb.h"
#include "tether/proxy/device/compat_device.hpp"
#include "wire.hpp"

namespace {

using namespace tether::proxy::device;
using tether::Millis;
using tether::proxy::Integrity;
using In = RocketryProto_ArduinoIn;
using Out = RocketryProto_ArduinoOut;
using Bytes = wire::Bytes;

std::string describe(const Out& out) {
  switch (out.which_data) {
    case RocketryProto_ArduinoOut_eventMessage_tag:
      return "event " + std::to_string(out.data.eventMessage.type) + " " + std::to_string(out.data.eventMessage.data);
    case RocketryProto_ArduinoOut_errorMessage_tag:
      return "error " + std::to_string(out.data.errorMessage.type) + " " + std::to_string(out.data.errorMessage.data);
    case RocketryProto_ArduinoOut_servoState_tag:
      return "servo " + std::to_string(out.data.servoState.pin) + " " + std::to_string(out.data.servoState.position);
    case RocketryProto_ArduinoOut_digitalState_tag:
      return "digital " + std::to_string(out.data.digitalState.pin) + " " +
             std::to_string(out.data.digitalState.activated ? 1 : 0);
    default:
      return "?";
  }
}

using Lines = std::vector<std::string>;

class CompatDeviceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    device.begin(0);
  }
  void feed(const Bytes& bytes) {
    for (const uint8_t byte : bytes) device.handle_byte(byte);
  }
  // Sends `in` as the deployed host does: 00 ‖ COBS(pb) ‖ 00.
  void send(const In& in) { feed(wire::frame(wire::encode(RocketryProto_ArduinoIn_fields, &in), Integrity::none, true)); }
  Bytes take_bytes() {
    Bytes bytes;
    bytes.swap(recorder.bytes);
    recorder.clear();
    return bytes;
  }
  Lines take() {
    Lines lines;
    for (const Out& out : wire::decode_all<Out>(recorder.bytes, Integrity::none, RocketryProto_ArduinoOut_fields)) {
      lines.push_back(describe(out));
    }
    recorder.clear();
    return lines;
  }

  wire::Recorder recorder;
  OutputTable outputs;
  CompatDevice device{outputs, recorder.sink(), &wire::Recorder::restart, &recorder};
  fake::Hardware& hw = fake::hardware();
};

// EventTypes: RESET 0, SERVO_INIT 1, SERVO_CONTROL 2, DIGITAL_INIT 3, DIGITAL_CONTROL 4.
// ErrorTypes: DECODE_ERROR 0, UNKNOWN_MESSAGE 1, PIN_NOT_INITIALIZED 2.

TEST_F(CompatDeviceTest, BootVector) {
  EXPECT_EQ(take_bytes(), (Bytes{0x02, 0x0a, 0x01, 0x00}));  // EventMessage{RESET}
}

TEST_F(CompatDeviceTest, DigitalControlOfAnUninitialisedPinVector) {
  take_bytes();
  feed({0x00, 0x07, 0x22, 0x04, 0x08, 0x0d, 0x10, 0x01, 0x00});  // DigitalControl{13, true}
  // EventMessage{DIGITAL_CONTROL, 13} = 0a 04 08 04 10 0d, then ErrorMessage{PIN_NOT_INITIALIZED, 13}.
  EXPECT_EQ(take_bytes(), (Bytes{0x07, 0x0a, 0x04, 0x08, 0x04, 0x10, 0x0d, 0x00,  //
                                 0x07, 0x12, 0x04, 0x08, 0x02, 0x10, 0x0d, 0x00}));
  EXPECT_FALSE(hw.pins[13].output);
}

TEST_F(CompatDeviceTest, ServoInitOfAPinThatDoesNotExistVector) {
  take();
  feed({0x00, 0x09, 0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09, 0x00});  // ServoInit{1823, 1231}
  EXPECT_EQ(take(), (Lines{"event 1 1823", "error 2 1823"}));
}

TEST_F(CompatDeviceTest, ServoControlVector) {
  take();
  feed({0x00, 0x08, 0x12, 0x05, 0x08, 0x05, 0x10, 0xb4, 0x01, 0x00});  // ServoControl{5, 180}
  EXPECT_EQ(take(), (Lines{"event 2 5", "error 2 5"}));
}

TEST_F(CompatDeviceTest, ResetVector) {
  take();
  feed({0x00, 0x02, 0x2a, 0x01, 0x00});  // Reset{}
  EXPECT_EQ(recorder.restarts, 1);
  EXPECT_TRUE(take().empty());  // nothing sent before restarting
}

TEST_F(CompatDeviceTest, DigitalStateVector) {
  In in = RocketryProto_ArduinoIn_init_zero;
  in.which_data = RocketryProto_ArduinoIn_digitalInit_tag;
  in.data.digitalInit.pin = 8;
  in.data.digitalInit.safeState = 0;
  send(in);
  take();
  device.poll(50);
  EXPECT_EQ(take_bytes(), (Bytes{0x05, 0x22, 0x02, 0x08, 0x08, 0x00}));  // DigitalState{8, false}
}

TEST_F(CompatDeviceTest, InitsAndControlsDriveThePins) {
  take();
  In in = RocketryProto_ArduinoIn_init_zero;
  in.which_data = RocketryProto_ArduinoIn_servoInit_tag;
  in.data.servoInit = {9, 90};
  send(in);
  in.which_data = RocketryProto_ArduinoIn_digitalInit_tag;
  in.data.digitalInit = {13, 7};  // uint32 safeState: non-zero is high
  send(in);
  EXPECT_EQ(take(), (Lines{"event 1 9", "event 3 13"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 1500);
  EXPECT_TRUE(hw.pins[13].level);
  in.which_data = RocketryProto_ArduinoIn_servoControl_tag;
  in.data.servoControl = {9, 180};
  send(in);
  in.which_data = RocketryProto_ArduinoIn_digitalControl_tag;
  in.data.digitalControl = {13, false};
  send(in);
  EXPECT_EQ(take(), (Lines{"event 2 9", "event 4 13"}));
  EXPECT_EQ(hw.pins[9].pulse_us, 2000);
  EXPECT_FALSE(hw.pins[13].level);
  in.which_data = RocketryProto_ArduinoIn_servoControl_tag;
  in.data.servoControl = {13, 10};  // a digital pin
  send(in);
  in.which_data = RocketryProto_ArduinoIn_servoInit_tag;
  in.data.servoInit = {5, 10};  // not a servo pin
  send(in);
  in.which_data = RocketryProto_ArduinoIn_digitalInit_tag;
  in.data.digitalInit = {0, 1};  // the UART
  send(in);
  EXPECT_EQ(take(), (Lines{"event 2 13", "error 2 13", "event 1 5", "error 2 5", "event 3 0", "error 2 0"}));
}

TEST_F(CompatDeviceTest, StatesEveryFiftyMillisecondsForEachInitialisedPin) {
  In in = RocketryProto_ArduinoIn_init_zero;
  in.which_data = RocketryProto_ArduinoIn_digitalInit_tag;
  in.data.digitalInit = {13, 1};
  send(in);
  in.which_data = RocketryProto_ArduinoIn_servoInit_tag;
  in.data.servoInit = {10, 45};
  send(in);
  take();
  for (Millis now = 1; now < 50; ++now) device.poll(now);
  EXPECT_TRUE(take().empty());
  device.poll(50);
  EXPECT_EQ(take(), (Lines{"servo 10 45", "digital 13 1"}));
  for (Millis now = 51; now < 100; ++now) device.poll(now);
  EXPECT_TRUE(take().empty());
  device.poll(100);
  EXPECT_EQ(take(), (Lines{"servo 10 45", "digital 13 1"}));
  device.poll(1000);  // a stalled loop: one round, no burst
  EXPECT_EQ(take().size(), 2u);
  device.poll(1049);
  EXPECT_TRUE(take().empty());
  device.poll(1050);
  EXPECT_EQ(take().size(), 2u);
}

TEST_F(CompatDeviceTest, NoStatesWithoutInitialisedPins) {
  take();
  for (Millis now = 1; now <= 500; ++now) device.poll(now);
  EXPECT_TRUE(take().empty());
}

TEST_F(CompatDeviceTest, MotorsAndUnknownMessages) {
  take();
  In in = RocketryProto_ArduinoIn_init_zero;
  in.which_data = RocketryProto_ArduinoIn_dcMotorInit_tag;
  send(in);
  in.which_data = RocketryProto_ArduinoIn_dcMotorControl_tag;
  send(in);
  in.which_data = RocketryProto_ArduinoIn_stepperMotorControl_tag;
  send(in);
  feed({0x00, 0x02, 0x4a, 0x01, 0x00});  // field 9 (a oneof case from a newer schema): skipped, no oneof
  EXPECT_EQ(take(), (Lines{"error 1 6", "error 1 7", "error 1 8", "error 1 0"}));
}

TEST_F(CompatDeviceTest, DecodeError) {
  take();
  feed({0x00, 0x03, 0x0a, 0x05, 0x00});  // a submessage running past the end
  EXPECT_EQ(take_bytes(), (Bytes{0x02, 0x12, 0x01, 0x00}));  // ErrorMessage{DECODE_ERROR}: empty submessage
  EXPECT_EQ(device.counters().decode_errors, 1u);
}

TEST_F(CompatDeviceTest, FramesWithoutTheLeadingDelimiterToo) {
  take();
  feed({0x07, 0x22, 0x04, 0x08, 0x0d, 0x10, 0x01, 0x00});
  EXPECT_EQ(take(), (Lines{"event 4 13", "error 2 13"}));
}

}  // namespace
