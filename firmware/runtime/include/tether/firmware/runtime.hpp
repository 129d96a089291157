/// @file runtime.hpp
/// The bare-metal runtime for the ATmega328P images (Arduino Uno, 16 MHz), in one include.
///
/// - `uart0.hpp`: interrupt-driven UART0 with compile-time ring sizes (`Uart0`, `TETHER_UART0_ISRS`).
/// - `clock.hpp`: `millis()`/`micros()` from Timer2 (Timer0/Timer1 stay free).
/// - `reset.hpp`: `system_reset()` through the watchdog, `reset_cause()`.
/// - `power.hpp`: `idle<Uart>()`, sleep until the next interrupt.
///
/// No heap, no C++ library, no virtual functions. A minimal image:
///
///     #include "tether/firmware/runtime.hpp"
///     using Serial = tether::firmware::Uart0<64, 64>;
///     TETHER_UART0_ISRS(Serial);
///     int main() {
///       tether::firmware::runtime_init<Serial>(115200);
///       for (;;) {
///         const int16_t byte = Serial::read();
///         if (byte < 0) { tether::firmware::idle<Serial>(); continue; }
///         Serial::write(static_cast<uint8_t>(byte));
///       }
///     }
#pragma once

#include <avr/interrupt.h>
#include <stdint.h>

#include "tether/firmware/clock.hpp"
#include "tether/firmware/power.hpp"
#include "tether/firmware/reset.hpp"
#include "tether/firmware/uart0.hpp"

namespace tether {
namespace firmware {

/// One-call setup: starts the 1 ms clock, opens `Uart` (a `Uart0<...>`) at `baud`, enables interrupts.
template <typename Uart>
void runtime_init(uint32_t baud) {
  clock_init();
  Uart::begin(baud);
  sei();
}

}  // namespace firmware
}  // namespace tether
