// AVR back end of the pin drivers (ATmega328P, Arduino Uno): see tether/proxy/device/hardware.hpp.
#include <avr/io.h>
#include <util/atomic.h>

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

// COM1A1 for D9 (OC1A), COM1B1 for D10 (OC1B).
uint8_t compare_output_bit(uint8_t pin) { return pin == kServoPinA ? _BV(COM1A1) : _BV(COM1B1); }

constexpr uint8_t kClockSelect = _BV(CS12) | _BV(CS11) | _BV(CS10);

void write_compare(uint8_t pin, uint16_t pulse_us) {
  const uint16_t value = servo_compare_value(pulse_us);
  // 16-bit timer registers go through the shared TEMP byte: no interrupt may touch Timer1 in between.
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (pin == kServoPinA) {
      OCR1A = value;
    } else {
      OCR1B = value;
    }
    // simavr 1.6 (the virtual Uno) applies a new OCR1x in fast PWM only when it reconfigures the timer,
    // which it does when the clock-select or mode bits change: stop the clock for one instruction and
    // restart it. On the chip this is harmless: TCNT1 keeps its value, the prescaler keeps running, so
    // at most one 0.5 us tick of this period is lost, and the new width still takes effect at BOTTOM
    // (OCR1x is double-buffered in mode 14).
    const uint8_t clock = TCCR1B;
    if ((clock & kClockSelect) != 0) {
      TCCR1B = static_cast<uint8_t>(clock & static_cast<uint8_t>(~kClockSelect));
      TCCR1B = clock;
    }
  }
}

void start_servo_timer() {
  if ((TCCR1B & kClockSelect) != 0) return;  // already running
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TCCR1B = 0;  // stopped while configuring
    TCCR1A = static_cast<uint8_t>(TCCR1A & (_BV(COM1A1) | _BV(COM1A0) | _BV(COM1B1) | _BV(COM1B0)));
    TCCR1A = static_cast<uint8_t>(TCCR1A | _BV(WGM11));  // mode 14: WGM13..10 = 1110, TOP = ICR1
    ICR1 = kServoTimerTop;
    TCNT1 = 0;
    TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);  // clk/8: 0.5 us per tick
  }
}

}  // namespace

void servo_attach(uint8_t pin, uint16_t pulse_us) {
  const PortBit bit = port_bit(pin);
  set_bits(bit.port, bit.mask, false);  // the pin's own level when OC1x is disconnected: low
  write_compare(pin, pulse_us);
  start_servo_timer();
  set_bits(&TCCR1A, compare_output_bit(pin), true);
  set_bits(bit.ddr, bit.mask, true);
}

void servo_write(uint8_t pin, uint16_t pulse_us) { write_compare(pin, pulse_us); }

void servo_detach(uint8_t pin) { set_bits(&TCCR1A, compare_output_bit(pin), false); }

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
