// The output registry: see tether/proxy/device/outputs.hpp.
#include "tether/proxy/device/outputs.hpp"

#include "tether/proxy/device/hardware.hpp"

namespace tether {
namespace proxy {
namespace device {

namespace {

PinResult check_pin(uint32_t pin) {
  if (!pin_exists(pin)) return PinResult::no_such_pin;
  if (is_uart_pin(pin)) return PinResult::uart_pin;
  return PinResult::ok;
}

}  // namespace

PinResult OutputTable::init_servo(uint32_t pin, int32_t safe_degrees) {
  const PinResult checked = check_pin(pin);
  if (checked != PinResult::ok) return checked;
  if (!can_drive_servo(pin)) return PinResult::not_servo_pin;
  if (!is_servo_degrees(safe_degrees)) return PinResult::out_of_range;
  Slot& slot = this->slot(pin);
  const uint8_t safe = clamp_degrees(safe_degrees);
  slot.safe = safe;
  if (slot.kind == OutputKind::servo) {
    drive(static_cast<uint8_t>(pin), safe);  // already pulsing: a new width (one copy of the write path)
    return PinResult::ok;
  }
  slot.kind = OutputKind::servo;
  slot.value = safe;
  hardware::servo_attach(static_cast<uint8_t>(pin), servo_pulse_us(safe));
  return PinResult::ok;
}

PinResult OutputTable::init_digital(uint32_t pin, bool safe_high) {
  const PinResult checked = check_pin(pin);
  if (checked != PinResult::ok) return checked;
  Slot& slot = this->slot(pin);
  // Level first: while Timer1 still drives a servo pin its PORT bit does not show, so the pin goes from
  // the last pulse straight to the safe level when the servo is detached after.
  hardware::digital_init(static_cast<uint8_t>(pin), safe_high);
  if (slot.kind == OutputKind::servo) hardware::servo_detach(static_cast<uint8_t>(pin));
  slot.kind = OutputKind::digital;
  slot.safe = safe_high ? 1 : 0;
  slot.value = slot.safe;
  return PinResult::ok;
}

// Out of line: both controls' checks share one copy (LTO inlined it into each; proxy.elf -40 B).
__attribute__((noinline)) PinResult OutputTable::check_control(uint32_t pin, OutputKind expected) const {
  const PinResult checked = check_pin(pin);
  if (checked != PinResult::ok) return checked;
  const OutputKind kind = slot(pin).kind;
  if (kind == OutputKind::none) return PinResult::not_initialised;
  if (kind != expected) return PinResult::wrong_kind;
  return PinResult::ok;
}

PinResult OutputTable::control_servo(uint32_t pin, int32_t degrees) {
  const PinResult checked = check_control(pin, OutputKind::servo);
  if (checked != PinResult::ok) return checked;
  if (!is_servo_degrees(degrees)) return PinResult::out_of_range;
  drive(static_cast<uint8_t>(pin), clamp_degrees(degrees));
  return PinResult::ok;
}

PinResult OutputTable::control_digital(uint32_t pin, bool high) {
  const PinResult checked = check_control(pin, OutputKind::digital);
  if (checked != PinResult::ok) return checked;
  drive(static_cast<uint8_t>(pin), high ? 1 : 0);
  return PinResult::ok;
}

void OutputTable::drive_safe() {
  for (uint8_t pin = kFirstOutputPin; pin < kPinCount; ++pin) {
    if (slot(pin).kind != OutputKind::none) drive(pin, slot(pin).safe);
  }
}

uint8_t OutputTable::initialised_count() const {
  uint8_t count = 0;
  for (const Slot& slot : slots_) {
    if (slot.kind != OutputKind::none) ++count;
  }
  return count;
}

void OutputTable::drive(uint8_t pin, uint8_t value) {
  Slot& slot = this->slot(pin);
  slot.value = value;
  if (slot.kind == OutputKind::servo) {
    hardware::servo_write(pin, servo_pulse_us(value));
  } else {
    hardware::digital_write(pin, value != 0);
  }
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
