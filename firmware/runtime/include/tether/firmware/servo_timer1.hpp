/// @file servo_timer1.hpp
/// Hobby-servo pulses on Timer1's two compare outputs (ATmega328P): D9 = OC1A, D10 = OC1B; 50 Hz frames,
/// pulse widths in microseconds. The one Timer1 servo driver of the firmware images (proxy, elcano-node,
/// romi-rover).
///
/// Timer1 runs fast PWM mode 14 (TOP = ICR1 = 39999, clk/8: 0.5 us per tick, 20 ms period); an output is
/// high from BOTTOM through the compare match, i.e. OCR1x + 1 ticks, so OCR1x = 2 * pulse_us - 1.
/// Contracts:
///   1. `attach` starts the timer if needed, then connects the output; the pin's own level while detached
///      is low. `detach` disconnects the output (the pin drops to its PORT level: low).
///   2. `write` takes effect from the next period (OCR1x is double-buffered in mode 14).
///   3. Safe to call with interrupts on: 16-bit registers are written atomically (they share TEMP).
/// simavr 1.6 (the virtual Uno) applies a new OCR1x in fast PWM only when it reconfigures the timer, which
/// it does when the clock-select bits change: `write` stops the clock for one instruction and restarts it.
/// On the chip that costs at most one 0.5 us tick of the current period.
#pragma once

#include <stdint.h>

namespace tether {
namespace firmware {
namespace servo_timer1 {

/// The two outputs.
enum class Output : uint8_t {
  d9,   ///< OC1A, PB1.
  d10,  ///< OC1B, PB2.
};

/// Timer1 TOP for a 20 ms period at 0.5 us per tick.
constexpr uint16_t kTop = 39999;

/// OCR1x for a pulse of `pulse_us` (0 keeps the output low: OCR1x 0 is one tick, see the data sheet).
constexpr uint16_t compare_value(uint16_t pulse_us) {
  return static_cast<uint16_t>(pulse_us == 0 ? 0u : 2u * static_cast<uint32_t>(pulse_us) - 1u);
}

/// Connects `output` with a pulse of `pulse_us`, starting the timer if it is not running.
void attach(Output output, uint16_t pulse_us);
/// New pulse width of `output` from the next period.
void write(Output output, uint16_t pulse_us);
/// Disconnects `output` (the pin goes low).
void detach(Output output);

}  // namespace servo_timer1
}  // namespace firmware
}  // namespace tether
