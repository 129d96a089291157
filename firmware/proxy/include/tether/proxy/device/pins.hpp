/// @file pins.hpp
/// The Arduino Uno's pins as the proxy devices see them, and the servo arithmetic. Pure, constexpr.
///
/// Pin numbers are Arduino numbers: D0..D13 = 0..13 (PD0..PD7, PB0..PB5), A0..A5 = 14..19 (PC0..PC5).
///   - D0/D1 are UART0 (the host link): never an output.
///   - Digital outputs: any of 2..19.
///   - Servo outputs: D9 (OC1A) and D10 (OC1B) only, on Timer1's hardware PWM (hardware.hpp, AVR
///     back end): fast PWM mode 14, TOP = ICR1 = 39999, clk/8 -> 0.5 us per tick, 20 ms period (50 Hz).
///
/// Servo positions are degrees 0..180 (values outside are clamped), driven as a pulse of
/// `1000 + degrees * 1000 / 180` us (integer division): 0 -> 1000 us, 90 -> 1500 us, 180 -> 2000 us.
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

/// Pulse width (us) for a position in degrees (clamped): 1000 + degrees * 1000 / 180.
constexpr uint16_t servo_pulse_us(int32_t degrees) {
  return static_cast<uint16_t>(kServoMinPulseUs +
                               static_cast<uint32_t>(clamp_degrees(degrees)) *
                                   static_cast<uint32_t>(kServoMaxPulseUs - kServoMinPulseUs) /
                                   static_cast<uint32_t>(kServoMaxDegrees));
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
