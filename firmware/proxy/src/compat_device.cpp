// Deployed-variant proxy device: see tether/proxy/device/compat_device.hpp for the wire behaviour.
#include "tether/proxy/device/compat_device.hpp"

#include <pb_decode.h>

#include "rocketry.pb.h"
#include "tether/core/execution_witness.hpp"
#include "tether/proxy/device/flash_descriptors.hpp"
#include "tether/proxy/device/hardware.hpp"

namespace tether {
namespace proxy {
namespace device {

static_assert(RocketryProto_ArduinoOut_size <= kMaxOutPayload, "an ArduinoOut must fit the send buffer");
static_assert(RocketryProto_ArduinoIn_size <= CompatDevice::kMaxPayload, "an ArduinoIn must fit the decoder");
#ifndef TETHER_PB_DESCRIPTORS_IN_FLASH
#error "rocketry.options must include nanopb_descriptors_in_flash.h: the descriptors are read from flash here"
#endif

namespace {

RocketryProto_ArduinoOut compat_out_message(pb_size_t which) {
  RocketryProto_ArduinoOut out = RocketryProto_ArduinoOut_init_zero;
  out.which_data = which;
  return out;
}

// D0/D1 are UART0's: their state is kept, the pins are left to the UART.
bool drives_pin(uint32_t pin) { return pin >= kFirstOutputPin; }

// Arduino's analogRead numbering for A0..A5; anything else has no ADC channel here.
bool adc_channel(uint32_t pin, uint8_t& channel) {
  if (pin < 14 || pin >= kPinCount) return false;
  channel = static_cast<uint8_t>(pin - 14u);
  return true;
}

// The RocketryProto descriptors are in flash (rocketry.options): nanopb decodes through a copy on the
// stack, in a frame of its own that is gone before the message is handled.
__attribute__((noinline)) bool decode_arduino_in(ByteView payload, RocketryProto_ArduinoIn* in) {
  const DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoIn)> fields(
      FlashDescriptor{RocketryProto_ArduinoIn_fields});
  return decode_message(fields.get(), payload, in);
}

}  // namespace

CompatDevice::CompatDevice(FrameSink sink, RestartFunction restart, void* restart_context)
    : sink_(sink),
      restart_(restart),
      restart_context_(restart_context),
      decoder_(Integrity::none, counters_.link),
      motors_() {
  for (uint8_t pin = 0; pin < kPinCount; ++pin) servo_position_[pin] = kUnsetPosition;
}

void CompatDevice::begin(Millis now) {
  hardware::load_cell_begin();
  next_states_.arm(now, kStatePeriodMs);
  RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_eventMessage_tag);
  out.data.eventMessage.type = RocketryProto_EventTypes_RESET;
  send(&out);
}

void CompatDevice::handle_byte(uint8_t byte) {
  if (decoder_.feed(byte) == DecodeStatus::frame) handle_payload(decoder_.frame());
}

size_t CompatDevice::handle_bytes(ByteView bytes) {
  const FeedResult fed = decoder_.feed(bytes);
  if (fed.status == DecodeStatus::frame) handle_payload(decoder_.frame());
  return fed.consumed;
}

void CompatDevice::poll(Millis now) {
  run_dc_motors();
  if (!next_states_.expired(now)) return;
  send_states();
  next_states_.arm(next_states_.at(), kStatePeriodMs);
  if (next_states_.expired(now)) next_states_.arm(now, kStatePeriodMs);  // fell behind: no burst
}

void CompatDevice::send_states() {
  for (uint8_t pin = 0; pin < kPinCount; ++pin) {
    if (!is_servo(pin)) continue;
    RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_servoState_tag);
    out.data.servoState.pin = pin;
    out.data.servoState.position = servo_position_[pin];
    send(&out);
  }
  for (uint8_t pin = 0; pin < kPinCount; ++pin) {
    if (!is_digital(pin)) continue;
    RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_digitalState_tag);
    out.data.digitalState.pin = pin;
    out.data.digitalState.activated = digital_level(pin);
    send(&out);
  }
  for (uint8_t i = 0; i < motor_count_; ++i) {
    const DcMotor& motor = motors_[i];
    RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_dcMotorState_tag);
    out.data.dcMotorState.motorForwardPin = motor.forward;
    out.data.dcMotorState.motorReversePin = motor.reverse;
    out.data.dcMotorState.position = motor.position;
    out.data.dcMotorState.direction = motor.direction;
    out.data.dcMotorState.minLimitSwitch = motor.min_limit;
    out.data.dcMotorState.maxLimitSwitch = motor.max_limit;
    send(&out);
  }
  uint32_t load = 0;
  if (hardware::load_cell_read(load)) {
    RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_loadCellState_tag);
    out.data.loadCellState.value = load;
    send(&out);
  }
}

void CompatDevice::handle_payload(ByteView payload) {
  RocketryProto_ArduinoIn in = RocketryProto_ArduinoIn_init_zero;
  if (!decode_arduino_in(payload, &in)) {
    add_one(counters_.decode_errors);
    send_error(RocketryProto_ErrorTypes_DECODE_ERROR, 0);
    return;
  }
  add_one(counters_.executed);
  switch (in.which_data) {
    case RocketryProto_ArduinoIn_servoInit_tag:
      init_servo(in.data.servoInit.pin);
      return;
    case RocketryProto_ArduinoIn_servoControl_tag:
      control_servo(in.data.servoControl.pin, in.data.servoControl.position);
      return;
    case RocketryProto_ArduinoIn_digitalInit_tag:
      init_digital(in.data.digitalInit.pin, in.data.digitalInit.safeState != 0);
      return;
    case RocketryProto_ArduinoIn_digitalControl_tag:
      control_digital(in.data.digitalControl.pin, in.data.digitalControl.activate);
      return;
    case RocketryProto_ArduinoIn_dcMotorInit_tag:
      init_dc_motor(&in.data.dcMotorInit);
      return;
    case RocketryProto_ArduinoIn_dcMotorControl_tag:
      control_dc_motor(in.data.dcMotorControl.pinForward, in.data.dcMotorControl.pinReverse,
                       in.data.dcMotorControl.position);
      return;
    case RocketryProto_ArduinoIn_reset_tag:
      if (restart_ != nullptr) restart_(restart_context_);  // on the AVR: flush, reset, no return
      return;
    default:  // StepperMotorControl and oneof cases this schema does not know: as deployed, data 0
      add_one(counters_.refused);
      send_error(RocketryProto_ErrorTypes_UNKNOWN_MESSAGE, 0);
      return;
  }
}

void CompatDevice::init_servo(uint32_t pin) {
  if (is_servo(pin)) return;  // deployed: a second ServoInit is ignored silently
  if (!compat_output_pin(pin) || !hardware::any_pin_servo_attach(static_cast<uint8_t>(pin), kArduinoServoAttachPulseUs)) {
    refuse_pin(pin);
    return;
  }
  servos_ |= bit(pin);
  servo_position_[pin] = kUnsetPosition;
  send_event(RocketryProto_EventTypes_SERVO_INIT, pin);
}

void CompatDevice::control_servo(uint32_t pin, int32_t position) {
  if (!is_servo(pin)) {
    refuse_pin(pin);
    return;
  }
  send_event(RocketryProto_EventTypes_SERVO_CONTROL, pin);
  const int16_t value = static_cast<int16_t>(position);  // the deployed firmware's `int`
  servo_position_[pin] = value;
  hardware::any_pin_servo_write(static_cast<uint8_t>(pin), arduino_servo_pulse_us(value));
  witness_executed(witness_key(static_cast<uint16_t>(pin), static_cast<uint16_t>(value)));  // pin, position
}

void CompatDevice::init_digital(uint32_t pin, bool safe_high) {
  if (is_digital(pin)) return;  // ignored silently, as a second ServoInit
  if (!compat_output_pin(pin)) {
    refuse_pin(pin);
    return;
  }
  if (drives_pin(pin)) hardware::digital_init(static_cast<uint8_t>(pin), safe_high);
  digitals_ |= bit(pin);
  set_level(pin, safe_high);
  send_event(RocketryProto_EventTypes_DIGITAL_INIT, pin);
}

void CompatDevice::control_digital(uint32_t pin, bool high) {
  if (!is_digital(pin)) {
    refuse_pin(pin);
    return;
  }
  send_event(RocketryProto_EventTypes_DIGITAL_CONTROL, pin);
  if (drives_pin(pin)) hardware::digital_write(static_cast<uint8_t>(pin), high);
  set_level(pin, high);
}

void CompatDevice::set_level(uint32_t pin, bool high) {
  if (high) {
    levels_ |= bit(pin);
  } else {
    levels_ &= ~bit(pin);
  }
}

CompatDevice::DcMotor* CompatDevice::find_dc_motor(uint32_t forward, uint32_t reverse) {
  for (uint8_t i = 0; i < motor_count_; ++i) {
    if (motors_[i].forward == forward && motors_[i].reverse == reverse) return &motors_[i];
  }
  return nullptr;
}

void CompatDevice::init_dc_motor(const void* message) {
  const RocketryProto_DCMotorInit& init = *static_cast<const RocketryProto_DCMotorInit*>(message);
  if (find_dc_motor(init.motorForwardPin, init.motorReversePin) != nullptr) return;  // ignored silently
  uint8_t channel = 0;
  const bool usable = motor_count_ < kMaxDcMotors && compat_output_pin(init.motorForwardPin) &&
                      compat_output_pin(init.motorReversePin) && compat_output_pin(init.limitSwitchMinPin) &&
                      compat_output_pin(init.limitSwitchMaxPin) && drives_pin(init.motorForwardPin) &&
                      drives_pin(init.motorReversePin) && drives_pin(init.limitSwitchMinPin) &&
                      drives_pin(init.limitSwitchMaxPin) && compat_output_pin(init.potentiometerPin) &&
                      adc_channel(init.potentiometerPin, channel);
  if (!usable) {
    refuse_pin(init.motorForwardPin);
    return;
  }
  DcMotor& motor = motors_[motor_count_++];
  motor.forward = static_cast<uint8_t>(init.motorForwardPin);
  motor.reverse = static_cast<uint8_t>(init.motorReversePin);
  motor.potentiometer = channel;
  motor.limit_min = static_cast<uint8_t>(init.limitSwitchMinPin);
  motor.limit_max = static_cast<uint8_t>(init.limitSwitchMaxPin);
  motor.power = static_cast<uint8_t>(init.motorPower > 255 ? 255 : init.motorPower);
  motor.direction = 0;
  motor.active = false;
  motor.target = 0;
  hardware::input_init(motor.limit_min, false);
  hardware::input_init(motor.limit_max, false);
  hardware::input_init(static_cast<uint8_t>(init.potentiometerPin), true);
  hardware::analog_write(motor.forward, 0);
  hardware::analog_write(motor.reverse, 0);
  motor.min_limit = hardware::input_read(motor.limit_min);
  motor.max_limit = hardware::input_read(motor.limit_max);
  motor.position = static_cast<int16_t>(hardware::analog_read(motor.potentiometer));
  send_event(RocketryProto_EventTypes_DC_MOTOR_INIT, motor.forward);
}

void CompatDevice::drive_dc_motor(DcMotor& motor, int8_t direction) {
  motor.direction = direction;
  hardware::analog_write(motor.forward, direction > 0 ? motor.power : 0);
  hardware::analog_write(motor.reverse, direction < 0 ? motor.power : 0);
}

void CompatDevice::control_dc_motor(uint32_t forward, uint32_t reverse, int32_t position) {
  DcMotor* motor = find_dc_motor(forward, reverse);
  if (motor == nullptr) {
    refuse_pin(forward);
    return;
  }
  send_event(RocketryProto_EventTypes_DC_MOTOR_CONTROL, forward);
  motor->target = position;
  motor->active = true;
  drive_dc_motor(*motor, motor->position < position ? 1 : (motor->position == position ? 0 : -1));
}

void CompatDevice::run_dc_motors() {
  for (uint8_t i = 0; i < motor_count_; ++i) {
    DcMotor& motor = motors_[i];
    const int16_t position = static_cast<int16_t>(hardware::analog_read(motor.potentiometer));
    motor.min_limit = hardware::input_read(motor.limit_min);
    motor.max_limit = hardware::input_read(motor.limit_max);
    if (motor.active) {
      const bool stop = (motor.direction < 0 && (motor.min_limit || position < motor.target)) ||
                        (motor.direction > 0 && (motor.max_limit || position > motor.target));
      if (stop) {
        motor.active = false;
        drive_dc_motor(motor, 0);
      }
    }
    motor.position = position;
  }
}

bool CompatDevice::send(const void* out_message) {
  if (send_message<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoOut)>(
          sink_, Integrity::none, false, FlashDescriptor{RocketryProto_ArduinoOut_fields}, out_message)) {
    return true;
  }
  add_one(counters_.send_failures);
  return false;
}

void CompatDevice::send_event(uint8_t type, uint32_t pin) {
  RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_eventMessage_tag);
  out.data.eventMessage.type = static_cast<RocketryProto_EventTypes>(type);
  out.data.eventMessage.data = static_cast<int32_t>(pin);
  send(&out);
}

void CompatDevice::refuse_pin(uint32_t pin) {
  add_one(counters_.refused);
  send_error(RocketryProto_ErrorTypes_PIN_NOT_INITIALIZED, static_cast<int32_t>(pin));
}

void CompatDevice::send_error(uint8_t type, int32_t data) {
  RocketryProto_ArduinoOut out = compat_out_message(RocketryProto_ArduinoOut_errorMessage_tag);
  out.data.errorMessage.type = static_cast<RocketryProto_ErrorTypes>(type);
  out.data.errorMessage.data = data;
  send(&out);
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
