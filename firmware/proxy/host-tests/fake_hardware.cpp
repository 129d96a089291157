// Host fake of the pin drivers: see fake_hardware.hpp.
#include "fake_hardware.hpp"

#include "tether/proxy/device/hardware.hpp"

namespace fake {

Hardware& hardware() {
  static Hardware state;
  return state;
}

void reset() { hardware() = Hardware(); }

}  // namespace fake

namespace tether::proxy::device::hardware {

namespace {
void log(const std::string& what, uint8_t pin, unsigned value) {
  fake::hardware().calls.push_back(what + " " + std::to_string(pin) + " " + std::to_string(value));
}
}  // namespace

void servo_attach(uint8_t pin, uint16_t pulse_us) {
  fake::Pin& p = fake::hardware().pins[pin];
  p.servo = true;
  p.output = true;
  p.level = false;
  p.pulse_us = pulse_us;
  log("attach", pin, pulse_us);
}

void servo_write(uint8_t pin, uint16_t pulse_us) {
  fake::hardware().pins[pin].pulse_us = pulse_us;
  log("write", pin, pulse_us);
}

void servo_detach(uint8_t pin) {
  fake::hardware().pins[pin].servo = false;
  log("detach", pin, 0);
}

void digital_init(uint8_t pin, bool high) {
  fake::Pin& p = fake::hardware().pins[pin];
  p.level = high;
  p.output = true;
  log("init", pin, high ? 1 : 0);
}

void digital_write(uint8_t pin, bool high) {
  fake::hardware().pins[pin].level = high;
  log("set", pin, high ? 1 : 0);
}

bool any_pin_servo_attach(uint8_t pin, uint16_t pulse_us) {
  fake::Hardware& hw = fake::hardware();
  if (hw.servo_channels_free == 0) return false;
  --hw.servo_channels_free;
  fake::Pin& p = hw.pins[pin];
  p.servo = true;
  p.output = true;
  p.pulse_us = pulse_us;
  log("servo", pin, pulse_us);
  return true;
}

void any_pin_servo_write(uint8_t pin, uint16_t pulse_us) {
  fake::hardware().pins[pin].pulse_us = pulse_us;
  log("write", pin, pulse_us);
}

void input_init(uint8_t pin, bool pull_up) {
  fake::Pin& p = fake::hardware().pins[pin];
  p.output = false;
  p.pull_up = pull_up;
  log("input", pin, pull_up ? 1 : 0);
}

bool input_read(uint8_t pin) { return fake::hardware().pins[pin].input_level; }

uint16_t analog_read(uint8_t channel) { return fake::hardware().adc[channel]; }

void analog_write(uint8_t pin, uint8_t value) {
  fake::Pin& p = fake::hardware().pins[pin];
  if (p.analog == value && p.output) return;  // the log shows changes only
  p.output = true;
  p.analog = value;
  log("analog", pin, value);
}

void load_cell_begin() { ++fake::hardware().load_cell_begun; }

bool load_cell_read(uint32_t& value) {
  if (!fake::hardware().load_cell_ready) return false;
  value = fake::hardware().load_cell_value;
  return true;
}

}  // namespace tether::proxy::device::hardware
