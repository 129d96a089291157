/// @file hx711.hpp
/// An HX711 load-cell amplifier on two pins: DOUT (data, input) and PD_SCK (clock, output). A reading is
/// 24 bits, MSB first, clocked out by 24 pulses; a 25th pulse selects channel A at gain 128 for the next
/// conversion. DOUT is low while a conversion is ready (high: still converting).
///
/// Each clock pulse is made with interrupts off (a high phase longer than 60 us powers the HX711 down), the
/// bits in between with interrupts on: other interrupt routines (servo pulses, UART) wait at most one
/// pulse, ~2 us. An unwired DOUT that reads low gives 0 (what the simulator shows on a floating input).
#pragma once

#include <stdint.h>

namespace tether {
namespace firmware {
namespace hx711 {

/// Makes `sck_pin` an output at low (the HX711 runs) and `dout_pin` an input without pull-up.
void begin(uint8_t dout_pin, uint8_t sck_pin);
/// When a conversion is ready, reads it into `value` (24-bit two's complement, sign-extended to 32 bits,
/// as a uint32) and returns true; false (nothing clocked) while the HX711 is converting.
bool read(uint8_t dout_pin, uint8_t sck_pin, uint32_t& value);

}  // namespace hx711
}  // namespace firmware
}  // namespace tether
