/// @file pin_registers.hpp
/// The registers behind an Arduino Uno pin number: D0..D7 = PD0..7, D8..D13 = PB0..5, A0..A5 (14..19) =
/// PC0..5. AVR only (includes <avr/io.h>); callers check the pin (0..19) first.
#pragma once

#include <avr/io.h>
#include <stdint.h>

namespace tether {
namespace firmware {

/// PINx (read), PORTx (level / pull-up), DDRx (direction) and the pin's bit in them.
struct PinRegisters {
  volatile uint8_t* in;    ///< PINx
  volatile uint8_t* port;  ///< PORTx
  volatile uint8_t* ddr;   ///< DDRx
  uint8_t mask;            ///< the pin's bit
};

/// The registers of Arduino pin `pin` (0..19).
inline PinRegisters pin_registers(uint8_t pin) {
  if (pin < 8) return PinRegisters{&PIND, &PORTD, &DDRD, static_cast<uint8_t>(1u << pin)};
  if (pin < 14) return PinRegisters{&PINB, &PORTB, &DDRB, static_cast<uint8_t>(1u << (pin - 8u))};
  return PinRegisters{&PINC, &PORTC, &DDRC, static_cast<uint8_t>(1u << (pin - 14u))};
}

/// Sets or clears `mask` in `reg` (read-modify-write; call with interrupts off when an interrupt routine
/// writes the same register).
inline void write_bits(volatile uint8_t* reg, uint8_t mask, bool on) {
  *reg = static_cast<uint8_t>(on ? (*reg | mask) : (*reg & static_cast<uint8_t>(~mask)));
}

}  // namespace firmware
}  // namespace tether
