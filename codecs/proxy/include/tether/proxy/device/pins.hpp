/// @file pins.hpp
/// The Arduino Uno's pins as the proxy devices see them, and the servo arithmetic. Pure, constexpr.
///
/// Pin numbers are Arduino numbers: D0..D13 = 0..13 (PD0..PD7, PB0..PB5), A0..A5 = 14..19 (PC0..PC5).
///   - D0/D1 are UART0 (the host link): never an output.
///   - Digital outputs: any of 2..19.
///   - Servo outputs: D9 (OC1A) and D10 (OC1B) only, on Timer1's hardware PWM (hardware.hpp, AVR
///     back end): fast PWM mode 14, TOP = ICR1 = 39999, clk/8 -> 0.5 us per tick, 20 ms period (50 Hz).
///
/// Primary mode (`proxy`): servo positions are degrees 0..180 (the device refuses others; `clamp_degrees`
/// bounds what reaches the driver), driven as a pulse of `1000 + degrees * 1000 / 180` us (integer
/// division): 0 -> 1000 us, 90 -> 1500 us, 180 -> 2000 us.
///
/// Compatibility mode (`proxy-compat`): the deployed firmware's Arduino Servo library arithmetic,
/// `arduino_servo_pulse_us`: 0..180 degrees -> 544..2400 us (90 -> 1472, 120 -> 1781, 45 -> 1008), any
/// pin (interrupt-driven pulses), the HX711 load cell on D12 (DOUT) / D13 (PD_SCK).
#pragma once

#include <stdint.h>

namespace tether {
namespace proxy {
namespace device {

/// Pins of an Uno: D0..D13 and A0..A5.
constexpr uint8_t kPinCount = 20;
/// First pin that may be an output (D0/D1 are the UART).
constexpr uint8_t kFirstOutputPin = 2;
/// The servo-capable pins: Timer1's compare outputs.
constexpr uint8_t kServoPinA = 9;   ///< OC1A (PB1)
constexpr uint8_t kServoPinB = 10;  ///< OC1B (PB2)

/// Largest servo position (degrees); positions are clamped to 0..kServoMaxDegrees.
constexpr int32_t kServoMaxDegrees = 180;
/// Pulse at 0 degrees (us).
constexpr uint16_t kServoMinPulseUs = 1000;
/// Pulse at 180 degrees (us).
constexpr uint16_t kServoMaxPulseUs = 2000;

/// True for a pin the board has (0..19).
constexpr bool pin_exists(uint32_t pin) { return pin < kPinCount; }
/// True for D0/D1, taken by the UART.
constexpr bool is_uart_pin(uint32_t pin) { return pin < kFirstOutputPin; }
/// True for a pin that can be a digital output (2..19).
constexpr bool can_drive_digital(uint32_t pin) { return pin >= kFirstOutputPin && pin < kPinCount; }
/// True for a pin that can drive a servo (9, 10).
constexpr bool can_drive_servo(uint32_t pin) { return pin == kServoPinA || pin == kServoPinB; }

/// A position clamped to 0..180 degrees.
constexpr uint8_t clamp_degrees(int32_t degrees) {
  return static_cast<uint8_t>(degrees < 0 ? 0 : (degrees > kServoMaxDegrees ? kServoMaxDegrees : degrees));
}

/// Pulse width (us) for a position in degrees (clamped): 1000 + degrees * 1000 / 180, computed as
/// degrees * 50 / 9 (the same fraction reduced by 20): 16-bit arithmetic, no 32-bit multiply or division
/// on the AVR (180 * 50 fits 16 bits).
constexpr uint16_t servo_pulse_us(int32_t degrees) {
  return static_cast<uint16_t>(kServoMinPulseUs + static_cast<uint16_t>(clamp_degrees(degrees) * 50u) / 9u);
}
static_assert((kServoMaxPulseUs - kServoMinPulseUs) * 9 == kServoMaxDegrees * 50,
              "servo_pulse_us's reduced fraction must be (max - min) / max degrees");

/// True when `degrees` is a primary-mode servo position (0..180): the device refuses others.
constexpr bool is_servo_degrees(int32_t degrees) { return degrees >= 0 && degrees <= kServoMaxDegrees; }

/// Arduino Servo library: pulse at 0 degrees, and the narrowest width `write` accepts (us).
constexpr int32_t kArduinoServoMinPulseUs = 544;
/// Arduino Servo library: pulse at 180 degrees, and the widest width (us).
constexpr int32_t kArduinoServoMaxPulseUs = 2400;
/// Arduino Servo library: the width `attach` starts with, before any `write` (us).
constexpr uint16_t kArduinoServoAttachPulseUs = 1500;

/// An angle value of Arduino's `Servo::write` clamped to 0..180 as the Servo library does.
constexpr int32_t arduino_servo_angle(int32_t value) {
  return value < 0 ? 0 : (value > kServoMaxDegrees ? kServoMaxDegrees : value);
}

/// The pulse Arduino's `Servo::write(value)` produces (the deployed firmware's servo arithmetic), `value`
/// being what it receives: the position as an AVR `int` (16 bits; the deployed firmware narrows the
/// protobuf int32 the same way). Below 544 it is an angle, clamped to 0..180 and mapped to
/// `544 + angle * 1856 / 180` us (integer division: 90 -> 1472, 120 -> 1781, 45 -> 1008, 180 -> 2400);
/// from 544 on it is a width in microseconds, at most 2400 (999 -> 999 us, 5000 -> 2400 us).
constexpr uint16_t arduino_servo_pulse_us(int16_t value) {
  // One return statement (C++11 constexpr): the Arduino IDE compiles the TetherProxy library as gnu++11.
  return static_cast<uint16_t>(
      value < kArduinoServoMinPulseUs
          ? kArduinoServoMinPulseUs + arduino_servo_angle(value) *
                                          (kArduinoServoMaxPulseUs - kArduinoServoMinPulseUs) / kServoMaxDegrees
          : (value > kArduinoServoMaxPulseUs ? kArduinoServoMaxPulseUs : value));
}

/// Compatibility mode: the HX711 load cell's data pin (D12, PB4) and clock pin (D13, PB5), where the
/// deployed firmware reads and clocks it (its PINB/PORTB bits; its A4/A5 constants are not what it drives:
/// docs/proxy.md, compatibility table). No servo, digital output or DC motor may use them.
constexpr uint8_t kLoadCellDataPin = 12;
constexpr uint8_t kLoadCellClockPin = 13;  ///< See kLoadCellDataPin.
/// Compatibility mode: true for a pin an output may use (0..19 but the load cell's D12/D13). D0/D1 are
/// accepted as the deployed firmware does; the UART keeps driving them (see compat_device.hpp).
constexpr bool compat_output_pin(uint32_t pin) {
  return pin < kPinCount && pin != kLoadCellDataPin && pin != kLoadCellClockPin;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
