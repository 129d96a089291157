// AVR back end of the compatibility-mode pin drivers (proxy-compat): see tether/proxy/device/hardware.hpp.
#include <avr/io.h>
#include <util/atomic.h>

#include "tether/firmware/adc.hpp"
#include "tether/firmware/hx711.hpp"
#include "tether/firmware/pin_registers.hpp"
#include "tether/firmware/servo_interrupt.hpp"
#include "tether/proxy/device/hardware.hpp"
#include "tether/proxy/device/pins.hpp"

namespace tether {
namespace proxy {
namespace device {
namespace hardware {

namespace {

constexpr uint8_t kPwmPinA = 6;  // OC0A
constexpr uint8_t kPwmPinB = 5;  // OC0B

void set_pin(uint8_t pin, bool output, bool level) {
  const firmware::PinRegisters bit = firmware::pin_registers(pin);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    firmware::write_bits(bit.port, bit.mask, level);
    firmware::write_bits(bit.ddr, bit.mask, output);
  }
}

// Timer0 fast PWM (mode 3, TOP 0xFF), clk/64: started by the first PWM output, then left running.
void start_timer0() {
  if ((TCCR0B & (_BV(CS02) | _BV(CS01) | _BV(CS00))) != 0) return;
  TCCR0A = static_cast<uint8_t>(TCCR0A | _BV(WGM01) | _BV(WGM00));
  TCCR0B = static_cast<uint8_t>(_BV(CS01) | _BV(CS00));
}

void connect_pwm(uint8_t pin, bool on) {
  const uint8_t com = pin == kPwmPinA ? _BV(COM0A1) : _BV(COM0B1);
  TCCR0A = static_cast<uint8_t>(on ? (TCCR0A | com) : (TCCR0A & static_cast<uint8_t>(~com)));
}

}  // namespace

bool any_pin_servo_attach(uint8_t pin, uint16_t pulse_us) { return firmware::servo_interrupt::attach(pin, pulse_us); }

void any_pin_servo_write(uint8_t pin, uint16_t pulse_us) { firmware::servo_interrupt::write(pin, pulse_us); }

void input_init(uint8_t pin, bool pull_up) { set_pin(pin, false, pull_up); }

bool input_read(uint8_t pin) {
  const firmware::PinRegisters bit = firmware::pin_registers(pin);
  return (*bit.in & bit.mask) != 0;
}

uint16_t analog_read(uint8_t channel) {
  static bool started = false;
  if (!started) {
    firmware::adc::begin(0);  // digital buffers stay on: A0..A5 may also be digital pins here
    started = true;
  }
  return firmware::adc::read(channel);
}

void analog_write(uint8_t pin, uint8_t value) {
  const bool pwm_pin = pin == kPwmPinA || pin == kPwmPinB;
  if (pwm_pin && value != 0 && value != 255) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      if (pin == kPwmPinA) {
        OCR0A = value;
      } else {
        OCR0B = value;
      }
      start_timer0();
      connect_pwm(pin, true);
    }
    set_pin(pin, true, false);
    return;
  }
  if (pwm_pin) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { connect_pwm(pin, false); }
  }
  set_pin(pin, true, value >= 128);
}

void load_cell_begin() { firmware::hx711::begin(kLoadCellDataPin, kLoadCellClockPin); }

bool load_cell_read(uint32_t& value) { return firmware::hx711::read(kLoadCellDataPin, kLoadCellClockPin, value); }

}  // namespace hardware
}  // namespace device
}  // namespace proxy
}  // namespace tether
