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
///
/// Compatibility-mode back end (src/hardware_compat_avr.cpp, used by `proxy-compat` only):
///   - Servos on any pin through the runtime's `servo_interrupt` driver (Timer1 compare-A interrupt, up
///     to 12 servos, Arduino Servo library timing). Timer1 is that driver's: an image uses `servo_*` or
///     `any_pin_servo_*`, never both.
///   - DC motor outputs: `analog_write` as Arduino's analogWrite: PWM on D5/D6 (Timer0, fast PWM, clk/64,
///     976 Hz), 0 -> low and 255 -> high everywhere; other pins: low below 128, high from 128 (Timer1 is
///     the servos', Timer2 the millisecond clock, so D3/D9/D10/D11 have no PWM here).
///   - Inputs: `input_init` / `input_read`, `analog_read` (A0..A5), the HX711 on D12 (DOUT) / D13 (PD_SCK).
/// D0/D1 belong to the UART: compat callers never pass them to these functions.
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

/// Compat: makes `pin` (0..19) a servo at `pulse_us`; false when every channel is taken.
bool any_pin_servo_attach(uint8_t pin, uint16_t pulse_us);
/// Compat: new width of an `any_pin_servo_attach`ed pin, from its next pulse.
void any_pin_servo_write(uint8_t pin, uint16_t pulse_us);
/// Compat: makes `pin` (2..19) an input, with the pull-up when `pull_up`.
void input_init(uint8_t pin, bool pull_up);
/// Compat: level of `pin` (2..19).
bool input_read(uint8_t pin);
/// Compat: 10-bit conversion of ADC channel `channel` (0..5 = A0..A5).
uint16_t analog_read(uint8_t channel);
/// Compat: makes `pin` (2..19) an output driven as Arduino's analogWrite(pin, value) does (see above).
void analog_write(uint8_t pin, uint8_t value);
/// Compat: prepares the HX711 on D12 (DOUT, an input) / D13 (PD_SCK, an output at low).
void load_cell_begin();
/// Compat: a ready HX711 conversion into `value` (24-bit two's complement sign-extended); false while
/// it converts (DOUT high).
bool load_cell_read(uint32_t& value);

}  // namespace hardware
}  // namespace device
}  // namespace proxy
}  // namespace tether
