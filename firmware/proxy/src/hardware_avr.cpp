// AVR back end of the pin drivers (ATmega328P, Arduino Uno): see tether/proxy/device/hardware.hpp.
#include <avr/io.h>
#include <util/atomic.h>

#include "tether/firmware/servo_timer1.hpp"
#include "tether/proxy/device/hardware.hpp"
#include "tether/proxy/device/pins.hpp"

namespace tether {
namespace proxy {
namespace device {
namespace hardware {

namespace {

// PORTx/DDRx of an Arduino pin: D0..D7 = PD0..7, D8..D13 = PB0..5, A0..A5 = PC0..5.
struct PortBit {
  volatile uint8_t* port;
  volatile uint8_t* ddr;
  uint8_t mask;
};

PortBit port_bit(uint8_t pin) {
  if (pin < 8) return PortBit{&PORTD, &DDRD, static_cast<uint8_t>(1u << pin)};
  if (pin < 14) return PortBit{&PORTB, &DDRB, static_cast<uint8_t>(1u << (pin - 8u))};
  return PortBit{&PORTC, &DDRC, static_cast<uint8_t>(1u << (pin - 14u))};
}

void set_bits(volatile uint8_t* reg, uint8_t mask, bool on) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    *reg = static_cast<uint8_t>(on ? (*reg | mask) : (*reg & static_cast<uint8_t>(~mask)));
  }
}

// The servo pins are Timer1's compare outputs (the runtime's driver).
firmware::servo_timer1::Output servo_output(uint8_t pin) {
  return pin == kServoPinA ? firmware::servo_timer1::Output::d9 : firmware::servo_timer1::Output::d10;
}

}  // namespace

void servo_attach(uint8_t pin, uint16_t pulse_us) { firmware::servo_timer1::attach(servo_output(pin), pulse_us); }

void servo_write(uint8_t pin, uint16_t pulse_us) { firmware::servo_timer1::write(servo_output(pin), pulse_us); }

void servo_detach(uint8_t pin) { firmware::servo_timer1::detach(servo_output(pin)); }

void digital_init(uint8_t pin, bool high) {
  const PortBit bit = port_bit(pin);
  set_bits(bit.port, bit.mask, high);
  set_bits(bit.ddr, bit.mask, true);
}

void digital_write(uint8_t pin, bool high) {
  const PortBit bit = port_bit(pin);
  set_bits(bit.port, bit.mask, high);
}

}  // namespace hardware
}  // namespace device
}  // namespace proxy
}  // namespace tether
