/// @file outputs.hpp
/// The registry of a proxy device's outputs: which pins the host initialised, as what, their safe values
/// and what they are driven to now. Used by the primary `proxy` image (`proxy-compat` keeps the deployed firmware's own pin model, compat_device.hpp).
///
/// Rules (ProxyDevice turns the results into Error messages):
///   - An init names the pin and its safe value and drives the pin to that safe value at once; it stays
///     there until the first control. Initialising a pin again is allowed: the new safe value replaces the
///     old one and the pin goes to it again; a servo pin re-initialised as digital stops its pulses first.
///   - Servo inits: D9/D10 only (`not_servo_pin` otherwise: nothing changes). Digital inits: 2..19.
///     D0/D1 are the UART (`uart_pin`), 20 and above do not exist (`no_such_pin`).
///   - A control needs the pin initialised as the same kind (`not_initialised`, `wrong_kind`). Servo
///     positions (controls and safe values) outside 0..180 degrees are refused (`out_of_range`: nothing
///     changes), never clamped: a host that sends 999 has a bug the device must not hide.
///   - `drive_safe` (the ping failsafe) puts every initialised pin at its safe value.
/// Pins are driven through hardware.hpp (registers on the AVR, a fake in the host tests).
///
/// RAM: 3 bytes per pin, 60 bytes. No heap.
#pragma once

#include <stdint.h>

#include "tether/proxy/device/pins.hpp"

namespace tether {
namespace proxy {
namespace device {

/// What a pin was initialised as.
enum class OutputKind : uint8_t {
  none = 0,  ///< Not initialised (an input, as after reset).
  digital,   ///< Digital output; value 0 (low) or 1 (high).
  servo,     ///< Servo output; value in degrees 0..180.
};

/// Outcome of an init or a control.
enum class PinResult : uint8_t {
  ok = 0,           ///< Done; the pin is driven to its new value.
  no_such_pin,      ///< The pin number is 20 or more.
  uart_pin,         ///< D0/D1: the UART's pins.
  not_servo_pin,    ///< A servo init on a pin other than D9/D10.
  not_initialised,  ///< A control of a pin never initialised.
  wrong_kind,       ///< A servo control of a digital pin, or the other way round.
  out_of_range,     ///< A servo position (or safe position) outside 0..180 degrees.
};

/// The outputs of one board. Not copyable (it mirrors hardware state).
class OutputTable {
 public:
  /// No pin initialised.
  OutputTable() = default;
  OutputTable(const OutputTable&) = delete;
  OutputTable& operator=(const OutputTable&) = delete;

  /// Claims `pin` as a servo with `safe_degrees` (0..180) and drives it there.
  PinResult init_servo(uint32_t pin, int32_t safe_degrees);
  /// Claims `pin` as a digital output with `safe_high` and drives it there.
  PinResult init_digital(uint32_t pin, bool safe_high);
  /// Moves an initialised servo to `degrees` (0..180).
  PinResult control_servo(uint32_t pin, int32_t degrees);
  /// Sets an initialised digital output.
  PinResult control_digital(uint32_t pin, bool high);
  /// Drives every initialised pin to its safe value (the failsafe).
  void drive_safe();

  /// What `pin` is (none for a pin outside 0..19).
  OutputKind kind(uint32_t pin) const { return can_drive_digital(pin) ? slot(pin).kind : OutputKind::none; }
  /// Value `pin` is driven to: degrees for a servo, 0/1 for a digital output, 0 when not initialised.
  uint8_t value(uint32_t pin) const { return can_drive_digital(pin) ? slot(pin).value : 0; }
  /// Safe value of `pin` (same units as `value`).
  uint8_t safe_value(uint32_t pin) const { return can_drive_digital(pin) ? slot(pin).safe : 0; }
  /// True when `pin` is initialised.
  bool initialised(uint32_t pin) const { return kind(pin) != OutputKind::none; }
  /// Number of initialised pins.
  uint8_t initialised_count() const;

 private:
  struct Slot {
    OutputKind kind = OutputKind::none;
    uint8_t value = 0;
    uint8_t safe = 0;
  };
  PinResult check_control(uint32_t pin, OutputKind expected) const;
  void drive(uint8_t pin, uint8_t value);
  // The slot of an output pin (kFirstOutputPin..kPinCount-1: the UART pins never get one).
  Slot& slot(uint32_t pin) { return slots_[pin - kFirstOutputPin]; }
  const Slot& slot(uint32_t pin) const { return slots_[pin - kFirstOutputPin]; }

  Slot slots_[kPinCount - kFirstOutputPin];
};

}  // namespace device
}  // namespace proxy
}  // namespace tether
