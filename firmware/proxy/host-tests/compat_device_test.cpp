// Host tests of CompatDevice (the deployed variant): the spec's vectors byte for byte, the behaviour measured
// on the deployed firmware (servo arithmetic, inits, refusals, pins, DC motors, load cell), as documented
// in compat_device.hpp.
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
    case RocketryProto_ArduinoOut_dcMotorState_tag: {
      const RocketryProto_DCMotorState& m = out.data.dcMotorState;
      return "motor " + std::to_string(m.motorForwardPin) + " " + std::to_string(m.motorReversePin) + " pos " +
             std::to_string(m.position) + " dir " + std::to_string(m.direction) + " limits " +
             std::to_string(m.minLimitSwitch ? 1 : 0) + std::to_string(m.maxLimitSwitch ? 1 : 0);
    }
    case RocketryProto_ArduinoOut_loadCellState_tag:
      return "load " + std::to_string(out.data.loadCellState.value);
    default:
      return "?";
  }
}

using Lines = std::vector<std::string>;

class CompatDeviceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    fake::hardware().load_cell_ready = false;  // no LoadCellState unless a test wants one
    device.begin(0);
  }
  void servo_init(uint32_t pin, int32_t safe) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_servoInit_tag;
    in.data.servoInit = {pin, safe};
    send(in);
  }
  void servo_control(uint32_t pin, int32_t position) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_servoControl_tag;
    in.data.servoControl = {pin, position};
    send(in);
  }
  void digital_init(uint32_t pin, uint32_t safe) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_digitalInit_tag;
    in.data.digitalInit = {pin, safe};
    send(in);
  }
  void digital_control(uint32_t pin, bool high) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_digitalControl_tag;
    in.data.digitalControl = {pin, high};
    send(in);
  }
  // DC motor: limit switches D2 (min) / D4 (max), potentiometer A0, forward D5, reverse D6.
  void dc_motor_init(uint32_t forward = 5, uint32_t reverse = 6, uint32_t power = 200, uint32_t pot = 14) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_dcMotorInit_tag;
    in.data.dcMotorInit = {2, 4, pot, forward, reverse, power};
    send(in);
  }
  void dc_motor_control(uint32_t forward, uint32_t reverse, int32_t position) {
    In in = RocketryProto_ArduinoIn_init_zero;
    in.which_data = RocketryProto_ArduinoIn_dcMotorControl_tag;
    in.data.dcMotorControl = {forward, reverse, position};
    send(in);
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
  CompatDevice device{recorder.sink(), &wire::Recorder::restart, &recorder};
  fake::Hardware& hw = fake::hardware();
};

// EventTypes: RESET 0, SERVO_INIT 1, SERVO_CONTROL 2, DIGITAL_INIT 3, DIGITAL_CONTROL 4, DC_MOTOR_INIT 5,
// DC_MOTOR_CONTROL 6.
// ErrorTypes: DECODE_ERROR 0, UNKNOWN_MESSAGE 1, PIN_NOT_INITIALIZED 2.

TEST_F(CompatDeviceTest, BootVector) {
  EXPECT_EQ(take_bytes(), (Bytes{0x02, 0x0a, 0x01, 0x00}));  // EventMessage{RESET}
}

TEST_F(CompatDeviceTest, ControlOfAnUninitialisedPinSendsOnlyTheErrorVector) {
  take_bytes();
  feed({0x00, 0x07, 0x22, 0x04, 0x08, 0x0d, 0x10, 0x01, 0x00});  // DigitalControl{13, true}
  // ErrorMessage{PIN_NOT_INITIALIZED, 13}, and no EventMessage{DIGITAL_CONTROL} before it.
  EXPECT_EQ(take_bytes(), (Bytes{0x07, 0x12, 0x04, 0x08, 0x02, 0x10, 0x0d, 0x00}));
  EXPECT_FALSE(hw.pins[13].output);
  feed({0x00, 0x08, 0x12, 0x05, 0x08, 0x05, 0x10, 0xb4, 0x01, 0x00});  // ServoControl{5, 180}
  EXPECT_EQ(take(), (Lines{"error 2 5"}));
  dc_motor_control(5, 6, 100);
  EXPECT_EQ(take(), (Lines{"error 2 5"}));
  EXPECT_EQ(device.counters().refused, 3u);
}

TEST_F(CompatDeviceTest, ServoInitOfAPinThatDoesNotExistIsOnlyAnError) {
  take();
  feed({0x00, 0x09, 0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09, 0x00});  // ServoInit{1823, 1231}
  EXPECT_EQ(take(), (Lines{"error 2 1823"}));
  EXPECT_TRUE(hw.calls.empty());
}

TEST_F(CompatDeviceTest, ResetVector) {
  take();
  feed({0x00, 0x02, 0x2a, 0x01, 0x00});  // Reset{}
  EXPECT_EQ(recorder.restarts, 1);
  EXPECT_TRUE(take().empty());  // nothing sent before restarting
}

TEST_F(CompatDeviceTest, DigitalStateVector) {
  digital_init(8, 0);
  take();
  device.poll(50);
  EXPECT_EQ(take_bytes(), (Bytes{0x05, 0x22, 0x02, 0x08, 0x08, 0x00}));  // DigitalState{8, false}
}

TEST_F(CompatDeviceTest, UndecodableFrameVectorAndEmptyFrames) {
  take();
  feed({0x00, 0x03, 0xff, 0xff, 0x00});  // measured on the deployed firmware
  EXPECT_EQ(take_bytes(), (Bytes{0x02, 0x12, 0x01, 0x00}));  // ErrorMessage{DECODE_ERROR}: empty submessage
  EXPECT_EQ(device.counters().decode_errors, 1u);
  feed({0x00, 0x00, 0x00});
  EXPECT_TRUE(take_bytes().empty());
}

TEST_F(CompatDeviceTest, ServoPulsesFollowTheArduinoServoLibrary) {
  // Servo::write: 0..180 degrees -> 544..2400 us (the deployed firmware's measurements), 544 and up are
  // microseconds (clamped to 2400), negative angles are 0, 181..543 are 180.
  static_assert(arduino_servo_pulse_us(90) == 1472, "");
  static_assert(arduino_servo_pulse_us(120) == 1781, "");
  static_assert(arduino_servo_pulse_us(45) == 1008, "");
  static_assert(arduino_servo_pulse_us(0) == 544, "");
  static_assert(arduino_servo_pulse_us(180) == 2400, "");
  static_assert(arduino_servo_pulse_us(-5) == 544, "");
  static_assert(arduino_servo_pulse_us(200) == 2400, "");
  static_assert(arduino_servo_pulse_us(543) == 2400, "");
  static_assert(arduino_servo_pulse_us(544) == 544, "");
  static_assert(arduino_servo_pulse_us(999) == 999, "");
  static_assert(arduino_servo_pulse_us(5000) == 2400, "");
  servo_init(9, 90);
  take();
  const struct {
    int32_t position;
    uint16_t pulse_us;
    int32_t reported;
  } cases[] = {{90, 1472, 90},  {120, 1781, 120}, {45, 1008, 45},   {0, 544, 0},     {180, 2400, 180},
               {-5, 544, -5},   {999, 999, 999},  {200, 2400, 200}, {70000, 2400, 4464}};  // 70000 as int16: 4464
  for (const auto& c : cases) {
    SCOPED_TRACE(c.position);
    servo_control(9, c.position);
    EXPECT_EQ(take(), (Lines{"event 2 9"}));
    EXPECT_EQ(hw.pins[9].pulse_us, c.pulse_us);
    EXPECT_EQ(device.servo_position(9), c.reported);
    device.send_states();
    EXPECT_EQ(take(), (Lines{"servo 9 " + std::to_string(c.reported)}));
  }
}

TEST_F(CompatDeviceTest, ServoInitAttachesAt1500AndReportsMinusOneUntilTheFirstControl) {
  take();  // the boot announcement
  servo_init(9, 30);  // safePosition is not applied
  EXPECT_EQ(take(), (Lines{"event 1 9"}));
  EXPECT_EQ(hw.calls, (std::vector<std::string>{"servo 9 1500"}));
  device.send_states();
  EXPECT_EQ(take(), (Lines{"servo 9 -1"}));
  servo_control(9, 120);
  take();
  EXPECT_EQ(hw.pins[9].pulse_us, 1781);
  device.send_states();
  EXPECT_EQ(take(), (Lines{"servo 9 120"}));
}

TEST_F(CompatDeviceTest, InitOfAnInitialisedPinIsIgnoredSilently) {
  servo_init(9, 30);
  servo_control(9, 120);
  digital_init(7, 1);
  take();
  hw.calls.clear();
  servo_init(9, 60);
  digital_init(7, 0);
  EXPECT_TRUE(take().empty());
  EXPECT_TRUE(hw.calls.empty());
  EXPECT_EQ(hw.pins[9].pulse_us, 1781);  // not re-attached, not driven to a safe position
  EXPECT_EQ(device.servo_position(9), 120);
  EXPECT_TRUE(hw.pins[7].level);
}

TEST_F(CompatDeviceTest, ServoOnAnyPinAndDigitalOutputsOnD1) {
  take();  // the boot announcement
  servo_init(3, 90);
  servo_init(18, 90);  // A4: an ordinary pin (the load cell is on D12/D13)
  digital_init(1, 0);  // the UART's TX: state kept and reported, the pin left to the UART
  EXPECT_EQ(take(), (Lines{"event 1 3", "event 1 18", "event 3 1"}));
  servo_control(3, 120);
  digital_control(1, true);
  EXPECT_EQ(take(), (Lines{"event 2 3", "event 4 1"}));
  EXPECT_EQ(hw.pins[3].pulse_us, 1781);
  EXPECT_FALSE(hw.pins[1].output);  // never touched
  EXPECT_TRUE(device.digital_level(1));
  device.send_states();
  EXPECT_EQ(take(), (Lines{"servo 3 120", "servo 18 -1", "digital 1 1"}));
}

TEST_F(CompatDeviceTest, InitsTheBoardCannotDoAreErrorsAndChangeNothing) {
  take();
  servo_init(12, 90);  // D12: the load cell's DOUT
  digital_init(13, 1);  // D13: the load cell's PD_SCK
  digital_init(20, 1);  // no such pin
  EXPECT_EQ(take(), (Lines{"error 2 12", "error 2 13", "error 2 20"}));
  for (uint32_t pin = 2; pin < 18; ++pin) {
    if (pin != 12 && pin != 13) servo_init(pin, 90);  // 14 inits, 12 servos: every channel
  }
  EXPECT_EQ(take().back(), "error 2 17");
  servo_init(18, 90);
  EXPECT_EQ(take(), (Lines{"error 2 18"}));
  EXPECT_FALSE(device.is_servo(18));
}

TEST_F(CompatDeviceTest, StatesEveryFiftyMillisecondsForEachInitialisedOutput) {
  digital_init(8, 1);
  servo_init(10, 45);
  take();
  for (Millis now = 1; now < 50; ++now) device.poll(now);
  EXPECT_TRUE(take().empty());
  device.poll(50);
  EXPECT_EQ(take(), (Lines{"servo 10 -1", "digital 8 1"}));
  for (Millis now = 51; now < 100; ++now) device.poll(now);
  EXPECT_TRUE(take().empty());
  device.poll(100);
  EXPECT_EQ(take(), (Lines{"servo 10 -1", "digital 8 1"}));
  device.poll(1000);  // a stalled loop: one round, no burst
  EXPECT_EQ(take().size(), 2u);
  device.poll(1049);
  EXPECT_TRUE(take().empty());
  device.poll(1050);
  EXPECT_EQ(take().size(), 2u);
}

TEST_F(CompatDeviceTest, LoadCellStateStreamsEveryFiftyMillisecondsWhenAConversionIsReady) {
  EXPECT_EQ(hw.load_cell_begun, 1);
  take();
  device.poll(50);
  EXPECT_TRUE(take().empty());  // HX711 converting: nothing
  hw.load_cell_ready = true;
  device.poll(100);
  EXPECT_EQ(take_bytes(), (Bytes{0x02, 0x3a, 0x01, 0x00}));  // LoadCellState{0}, as measured
  hw.load_cell_value = 0xFFFFFF85u;  // -123, sign-extended
  device.poll(150);
  EXPECT_EQ(take(), (Lines{"load 4294967173"}));
}

TEST_F(CompatDeviceTest, DcMotorDrivesTowardsItsTargetAndStopsThere) {
  take();  // the boot announcement
  hw.adc[0] = 300;
  dc_motor_init();
  EXPECT_EQ(take(), (Lines{"event 5 5"}));
  EXPECT_EQ(hw.calls, (std::vector<std::string>{"input 2 0", "input 4 0", "input 14 1", "analog 5 0", "analog 6 0"}));
  dc_motor_control(5, 6, 500);
  EXPECT_EQ(take(), (Lines{"event 6 5"}));
  EXPECT_EQ(hw.pins[5].analog, 200);  // forward at motorPower
  EXPECT_EQ(hw.pins[6].analog, 0);
  device.send_states();
  EXPECT_EQ(take(), (Lines{"motor 5 6 pos 300 dir 1 limits 00"}));
  hw.adc[0] = 450;
  device.poll(1);
  EXPECT_EQ(hw.pins[5].analog, 200);  // not there yet
  hw.adc[0] = 501;
  device.poll(2);
  EXPECT_EQ(hw.pins[5].analog, 0);  // passed the target: stopped
  device.send_states();
  EXPECT_EQ(take(), (Lines{"motor 5 6 pos 501 dir 0 limits 00"}));
  dc_motor_control(5, 6, 100);
  EXPECT_EQ(hw.pins[6].analog, 200);  // reverse
  hw.pins[2].input_level = true;      // the min limit switch closes
  device.poll(3);
  EXPECT_EQ(hw.pins[6].analog, 0);
  device.send_states();
  EXPECT_EQ(take(), (Lines{"event 6 5", "motor 5 6 pos 501 dir 0 limits 10"}));
  dc_motor_control(5, 6, 501);  // already there
  EXPECT_EQ(hw.pins[5].analog, 0);
  EXPECT_EQ(hw.pins[6].analog, 0);
}

TEST_F(CompatDeviceTest, DcMotorInitsAreKeyedByTheirPinsAndBounded) {
  take();  // the boot announcement
  dc_motor_init(5, 6);
  dc_motor_init(5, 6, 100);       // known: ignored silently
  dc_motor_init(3, 8, 200, 3);    // potentiometer off A0..A5
  dc_motor_init(7, 8, 1000);      // power above 255 drives as 255
  dc_motor_init(10, 11);          // a third motor
  EXPECT_EQ(take(), (Lines{"event 5 5", "error 2 3", "event 5 7", "error 2 10"}));
  hw.adc[0] = 10;
  device.poll(1);
  dc_motor_control(7, 8, 20);
  EXPECT_EQ(hw.pins[7].analog, 255);
  dc_motor_control(5, 7, 20);  // no such pair
  EXPECT_EQ(take(), (Lines{"event 6 7", "error 2 5"}));
}

TEST_F(CompatDeviceTest, StepperAndUnknownMessagesAnswerUnknownMessageWithData0) {
  take();
  In in = RocketryProto_ArduinoIn_init_zero;
  in.which_data = RocketryProto_ArduinoIn_stepperMotorControl_tag;
  in.data.stepperMotorControl.speed = 10;
  send(in);
  feed({0x00, 0x02, 0x4a, 0x01, 0x00});  // field 9 (a oneof case from a newer schema): skipped, no oneof
  EXPECT_EQ(take(), (Lines{"error 1 0", "error 1 0"}));
}

TEST_F(CompatDeviceTest, FramesWithoutTheLeadingDelimiterToo) {
  digital_init(8, 0);
  take();
  feed({0x07, 0x22, 0x04, 0x08, 0x08, 0x10, 0x01, 0x00});  // DigitalControl{8, true}
  EXPECT_EQ(take(), (Lines{"event 4 8"}));
}

// The HX711 is where the deployed firmware clocks and reads it (D13 / D12, docs/proxy.md): no init may
// take those pins, whatever its kind, and A4/A5 (where its constants point) are ordinary pins.
TEST_F(CompatDeviceTest, TheLoadCellsPinsD12AndD13RefuseEveryInitAndA4A5AreOrdinaryPins) {
  static_assert(kLoadCellDataPin == 12 && kLoadCellClockPin == 13, "the deployed board's wiring");
  take();  // the boot announcement
  servo_init(12, 90);
  servo_init(13, 90);
  digital_init(12, 0);
  digital_init(13, 1);
  dc_motor_init(13, 6);  // forward on the clock
  dc_motor_init(5, 12);  // reverse on the data pin
  In limits = RocketryProto_ArduinoIn_init_zero;
  limits.which_data = RocketryProto_ArduinoIn_dcMotorInit_tag;
  limits.data.dcMotorInit = {12, 13, 14, 5, 6, 200};  // limit switches on the load cell's pins
  send(limits);
  EXPECT_EQ(take(), (Lines{"error 2 12", "error 2 13", "error 2 12", "error 2 13", "error 2 13", "error 2 5",
                           "error 2 5"}));
  EXPECT_TRUE(hw.calls.empty());
  EXPECT_FALSE(device.is_servo(13));
  EXPECT_FALSE(device.is_digital(13));
  digital_control(13, true);  // not a digital output: only the error
  EXPECT_EQ(take(), (Lines{"error 2 13"}));
  EXPECT_EQ(device.counters().refused, 8u);
  digital_init(19, 1);           // A5 (a servo on A4: ServoOnAnyPinAndDigitalOutputsOnD1)
  dc_motor_init(5, 6, 200, 18);  // the potentiometer on A4
  EXPECT_EQ(take(), (Lines{"event 3 19", "event 5 5"}));
  EXPECT_TRUE(hw.pins[19].output);
  EXPECT_TRUE(hw.pins[19].level);
  EXPECT_EQ(hw.calls[0], "init 19 1");
  EXPECT_EQ(hw.calls[3], "input 18 1");
}

}  // namespace
