// Timer1 servo outputs; see servo_timer1.hpp.
#include "tether/firmware/servo_timer1.hpp"

#include <avr/io.h>
#include <util/atomic.h>

namespace tether {
namespace firmware {
namespace servo_timer1 {

namespace {

constexpr uint8_t kClockSelect = _BV(CS12) | _BV(CS11) | _BV(CS10);

uint8_t port_bit(Output output) { return output == Output::d9 ? _BV(PB1) : _BV(PB2); }
uint8_t compare_output_bit(Output output) { return output == Output::d9 ? _BV(COM1A1) : _BV(COM1B1); }

// Sets OCR1x; simavr applies it on a timer reconfiguration only (see the header), so a running timer's
// clock is stopped and restarted.
void set_compare(Output output, uint16_t pulse_us) {
  const uint16_t value = compare_value(pulse_us);
  if (output == Output::d9) {
    OCR1A = value;
  } else {
    OCR1B = value;
  }
  const uint8_t clock = TCCR1B;
  if ((clock & kClockSelect) != 0) {
    TCCR1B = static_cast<uint8_t>(clock & static_cast<uint8_t>(~kClockSelect));
    TCCR1B = clock;
  }
}

void start_timer() {
  if ((TCCR1B & kClockSelect) != 0) return;  // already running
  TCCR1B = 0;                                // stopped while configuring
  TCCR1A = static_cast<uint8_t>(TCCR1A & (_BV(COM1A1) | _BV(COM1A0) | _BV(COM1B1) | _BV(COM1B0)));
  TCCR1A = static_cast<uint8_t>(TCCR1A | _BV(WGM11));  // mode 14: WGM13..10 = 1110, TOP = ICR1
  ICR1 = kTop;
  TCNT1 = 0;
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);  // clk/8: 0.5 us per tick
}

}  // namespace

void attach(Output output, uint16_t pulse_us) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    PORTB = static_cast<uint8_t>(PORTB & static_cast<uint8_t>(~port_bit(output)));  // low while detached
    set_compare(output, pulse_us);
    start_timer();
    TCCR1A = static_cast<uint8_t>(TCCR1A | compare_output_bit(output));
    DDRB = static_cast<uint8_t>(DDRB | port_bit(output));
  }
}

void write(Output output, uint16_t pulse_us) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { set_compare(output, pulse_us); }
}

void detach(Output output) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TCCR1A = static_cast<uint8_t>(TCCR1A & static_cast<uint8_t>(~compare_output_bit(output)));
  }
}

}  // namespace servo_timer1
}  // namespace firmware
}  // namespace tether
