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

}  // namespace tether::proxy::device::hardware
