// Deployed-variant proxy device: see tether/proxy/device/compat_device.hpp for the wire behaviour.
#include "tether/proxy/device/compat_device.hpp"

#include <pb_decode.h>

#include "rocketry.pb.h"

namespace tether {
namespace proxy {
namespace device {

static_assert(RocketryProto_ArduinoOut_size <= kMaxOutPayload, "an ArduinoOut must fit the send buffer");
static_assert(RocketryProto_ArduinoIn_size <= CompatDevice::kMaxPayload, "an ArduinoIn must fit the decoder");

namespace {

RocketryProto_ArduinoOut out_message(pb_size_t which) {
  RocketryProto_ArduinoOut out = RocketryProto_ArduinoOut_init_zero;
  out.which_data = which;
  return out;
}

}  // namespace

CompatDevice::CompatDevice(OutputTable& outputs, FrameSink sink, RestartFunction restart, void* restart_context)
    : outputs_(&outputs),
      sink_(sink),
      restart_(restart),
      restart_context_(restart_context),
      decoder_(Integrity::none, counters_.link) {}

void CompatDevice::begin(Millis now) {
  next_states_.arm(now, kStatePeriodMs);
  RocketryProto_ArduinoOut out = out_message(RocketryProto_ArduinoOut_eventMessage_tag);
  out.data.eventMessage.type = RocketryProto_EventTypes_RESET;
  send(&out);
}

void CompatDevice::handle_byte(uint8_t byte) {
  const FrameEvent event = decoder_.feed(byte);
  if (event.kind == FrameEvent::Kind::payload) handle_payload(event.payload);
}

void CompatDevice::poll(Millis now) {
  if (!next_states_.expired(now)) return;
  send_states();
  next_states_.arm(next_states_.at(), kStatePeriodMs);
  if (next_states_.expired(now)) next_states_.arm(now, kStatePeriodMs);  // fell behind: no burst
}

void CompatDevice::send_states() {
  for (uint8_t pin = 0; pin < kPinCount; ++pin) {
    const OutputKind kind = outputs_->kind(pin);
    if (kind == OutputKind::servo) {
      RocketryProto_ArduinoOut out = out_message(RocketryProto_ArduinoOut_servoState_tag);
      out.data.servoState.pin = pin;
      out.data.servoState.position = outputs_->value(pin);
      send(&out);
    } else if (kind == OutputKind::digital) {
      RocketryProto_ArduinoOut out = out_message(RocketryProto_ArduinoOut_digitalState_tag);
      out.data.digitalState.pin = pin;
      out.data.digitalState.activated = outputs_->value(pin) != 0;
      send(&out);
    }
  }
}

void CompatDevice::handle_payload(ByteView payload) {
  RocketryProto_ArduinoIn in = RocketryProto_ArduinoIn_init_zero;
  pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
  if (!pb_decode(&stream, RocketryProto_ArduinoIn_fields, &in)) {
    ++counters_.decode_errors;
    send_error(RocketryProto_ErrorTypes_DECODE_ERROR, 0);
    return;
  }
  ++counters_.executed;
  uint32_t pin = 0;
  PinResult result = PinResult::ok;
  switch (in.which_data) {
    case RocketryProto_ArduinoIn_servoInit_tag:
      pin = in.data.servoInit.pin;
      send_event(RocketryProto_EventTypes_SERVO_INIT, pin);
      result = outputs_->init_servo(pin, in.data.servoInit.safePosition);
      break;
    case RocketryProto_ArduinoIn_servoControl_tag:
      pin = in.data.servoControl.pin;
      send_event(RocketryProto_EventTypes_SERVO_CONTROL, pin);
      result = outputs_->control_servo(pin, in.data.servoControl.position);
      break;
    case RocketryProto_ArduinoIn_digitalInit_tag:
      pin = in.data.digitalInit.pin;
      send_event(RocketryProto_EventTypes_DIGITAL_INIT, pin);
      result = outputs_->init_digital(pin, in.data.digitalInit.safeState != 0);
      break;
    case RocketryProto_ArduinoIn_digitalControl_tag:
      pin = in.data.digitalControl.pin;
      send_event(RocketryProto_EventTypes_DIGITAL_CONTROL, pin);
      result = outputs_->control_digital(pin, in.data.digitalControl.activate);
      break;
    case RocketryProto_ArduinoIn_reset_tag:
      if (restart_ != nullptr) restart_(restart_context_);  // on the AVR: flush, reset, no return
      return;
    default:  // DC motor, stepper (not driven here) and oneof cases this schema does not know
      ++counters_.refused;
      send_error(RocketryProto_ErrorTypes_UNKNOWN_MESSAGE, static_cast<int32_t>(in.which_data));
      return;
  }
  if (result != PinResult::ok) {
    ++counters_.refused;
    send_error(RocketryProto_ErrorTypes_PIN_NOT_INITIALIZED, static_cast<int32_t>(pin));
  }
}

bool CompatDevice::send(const void* out_message) {
  if (send_message(sink_, Integrity::none, false, RocketryProto_ArduinoOut_fields, out_message)) return true;
  ++counters_.send_failures;
  return false;
}

void CompatDevice::send_event(uint8_t type, uint32_t pin) {
  RocketryProto_ArduinoOut out = out_message(RocketryProto_ArduinoOut_eventMessage_tag);
  out.data.eventMessage.type = static_cast<RocketryProto_EventTypes>(type);
  out.data.eventMessage.data = static_cast<int32_t>(pin);
  send(&out);
}

void CompatDevice::send_error(uint8_t type, int32_t data) {
  RocketryProto_ArduinoOut out = out_message(RocketryProto_ArduinoOut_errorMessage_tag);
  out.data.errorMessage.type = static_cast<RocketryProto_ErrorTypes>(type);
  out.data.errorMessage.data = data;
  send(&out);
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
