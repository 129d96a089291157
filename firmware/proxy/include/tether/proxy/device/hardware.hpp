/// @file hardware.hpp
/// The pin drivers: the only code that touches the MCU's output registers. Chosen at link time.
///
/// `OutputTable` (outputs.hpp) decides WHAT a pin does and calls these functions to do it. The AVR back end
/// (src/hardware_avr.cpp, in the `tether_proxy_device` library) drives the ATmega328P's registers; the host
/// tests link a fake that records the calls. Callers have validated the pin (pins.hpp) before calling.
///
/// AVR back end:
///   - Digital outputs through the port registers (PORTx/DDRx of PD/PB/PC), each read-modify-write in an
///     atomic block. `digital_init` writes the level before switching the pin to output, so an output
///     never glitches to the other level on its way to the safe value.
///   - Servos on Timer1's hardware PWM: fast PWM mode 14 (WGM13:0 = 1110), TOP = ICR1 = 39999, clk/8:
///     0.5 us per tick, a 20 ms period (50 Hz). OC1A drives D9, OC1B drives D10 (COM1x1: non-inverting,
///     high from BOTTOM to the compare match). Timer1 starts at the first `servo_attach` and then runs
///     for good. OCR1x is double-buffered in this mode: a new width takes effect at the next period, so a
///     pulse is never cut short. The CPU does no work per pulse (no interrupt).
///   - `servo_detach` disconnects OC1x from the pin, which then follows its PORT bit: low, or the level a
///     `digital_init` wrote while the servo was still attached (how OutputTable switches a pin to digital).
#pragma once

#include <stdint.h>

namespace tether {
namespace proxy {
namespace device {
namespace hardware {

/// Makes `pin` (9 or 10) a servo output with pulses of `pulse_us` microseconds every 20 ms.
void servo_attach(uint8_t pin, uint16_t pulse_us);
/// Changes the pulse of an attached servo pin (from the next period on).
void servo_write(uint8_t pin, uint16_t pulse_us);
/// Stops driving pulses on `pin` (9 or 10); it stays an output at its PORT level.
void servo_detach(uint8_t pin);
/// Makes `pin` (2..19) a digital output at `high` (level first, then direction).
void digital_init(uint8_t pin, bool high);
/// Sets the level of a digital output pin.
void digital_write(uint8_t pin, bool high);

}  // namespace hardware
}  // namespace device
}  // namespace proxy
}  // namespace tether
