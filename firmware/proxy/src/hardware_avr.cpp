// AVR back end of the pin drivers (ATmega328P, Arduino Uno): see tether/proxy/device/hardware.hpp.
#include <avr/io.h>
#include <util/atomic.h>

#include "tether/firmware/pin_registers.hpp"
#include "tether/firmware/servo_timer1.hpp"
#include "tether/proxy/device/hardware.hpp"
#include "tether/proxy/device/pins.hpp"

namespace tether {
namespace proxy {
namespace device {
namespace hardware {

namespace {

// The servo pins are Timer1's compare outputs (the runtime's driver).
firmware::servo_timer1::Output servo_output(uint8_t pin) {
  return pin == kServoPinA ? firmware::servo_timer1::Output::d9 : firmware::servo_timer1::Output::d10;
}

}  // namespace

void servo_attach(uint8_t pin, uint16_t pulse_us) { firmware::servo_timer1::attach(servo_output(pin), pulse_us); }

void servo_write(uint8_t pin, uint16_t pulse_us) { firmware::servo_timer1::write(servo_output(pin), pulse_us); }

void servo_detach(uint8_t pin) { firmware::servo_timer1::detach(servo_output(pin)); }

void digital_init(uint8_t pin, bool high) {
  const firmware::PinRegisters bit = firmware::pin_registers(pin);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    firmware::write_bits(bit.port, bit.mask, high);
    firmware::write_bits(bit.ddr, bit.mask, true);
  }
}

void digital_write(uint8_t pin, bool high) {
  const firmware::PinRegisters bit = firmware::pin_registers(pin);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { firmware::write_bits(bit.port, bit.mask, high); }
}

}  // namespace hardware
}  // namespace device
}  // namespace proxy
}  // namespace tether
