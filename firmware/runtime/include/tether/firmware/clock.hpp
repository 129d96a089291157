/// @file clock.hpp
/// Millisecond clock on Timer2, leaving Timer0 and Timer1 to the application (PWM, servos, capture).
///
/// Timer2 runs in CTC mode at F_CPU / 64 / 250 = exactly 1 kHz at 16 MHz (prescaler 64, OCR2A = 249);
/// its compare interrupt counts milliseconds and also wakes `idle()` once per millisecond, so a main
/// loop checking deadlines sleeps at most 1 ms past them. Cost: Timer2's PWM outputs are gone, i.e. no
/// analogWrite-style PWM on Uno pins 11 (OC2A) and 3 (OC2B), and no tone() on Timer2.
#pragma once

#include <stdint.h>

#include "tether/core/time.hpp"

namespace tether {
namespace firmware {

/// Starts Timer2 as the 1 kHz tick and resets `millis()` to 0. Interrupts must be enabled globally
/// (`sei()`, or `runtime_init`) for the clock to advance.
void clock_init();

/// Milliseconds since `clock_init()` (wraps after 49.7 days; compare with tick_reached & co.).
tether::Millis millis();

/// The low byte of `millis()`: one load, no interrupt lock (a loop that only asks whether the clock
/// ticked, e.g. after each wake by the UART).
uint8_t millis_low_byte();

/// Microseconds since `clock_init()`, 4 us resolution (one Timer2 count); wraps after 71.6 minutes.
uint32_t micros();

}  // namespace firmware
}  // namespace tether
