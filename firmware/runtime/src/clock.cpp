// Timer2 millisecond tick: see tether/firmware/clock.hpp.
#include "tether/firmware/clock.hpp"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "tether/core/counters.hpp"

static_assert(F_CPU == 16000000UL, "Timer2 tick settings (prescaler 64, OCR2A 249) assume 16 MHz");

namespace {

constexpr uint8_t kTicksPerMillisecond = 250;    // OCR2A + 1
constexpr uint8_t kMicrosecondsPerTick = 4;      // 64 / 16 MHz

volatile tether::Millis g_millis = 0;

}  // namespace

ISR(TIMER2_COMPA_vect) { tether::add_one_in_interrupt(g_millis); }

namespace tether {
namespace firmware {

void clock_init() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TIMSK2 = 0;
    TCCR2B = 0;  // stop while configuring
    ASSR = 0;    // clocked from the CPU clock, not the 32 kHz crystal input
    TCCR2A = _BV(WGM21);               // CTC: count 0..OCR2A, then restart
    OCR2A = kTicksPerMillisecond - 1;
    TCNT2 = 0;
    TIFR2 = _BV(OCF2A) | _BV(OCF2B) | _BV(TOV2);  // drop stale flags (write 1 to clear)
    g_millis = 0;
    TIMSK2 = _BV(OCIE2A);
    TCCR2B = _BV(CS22);  // Timer2's clk/64 (its prescaler table differs from Timer0/1)
  }
}

tether::Millis millis() {
  tether::Millis now;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = g_millis; }
  return now;
}

// The low byte alone (the AVR is little-endian): a volatile uint32_t read loads all four.
uint8_t millis_low_byte() { return *reinterpret_cast<const volatile uint8_t*>(&g_millis); }

uint32_t micros() {
  tether::Millis ms;
  uint8_t ticks;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    ms = g_millis;
    ticks = TCNT2;
    // The counter restarted but the interrupt could not run yet: that millisecond is not in g_millis.
    // A count at OCR2A means the match is still to come, so its flag (if set) is the previous one's.
    if ((TIFR2 & _BV(OCF2A)) != 0 && ticks < kTicksPerMillisecond - 1) ++ms;
  }
  return ms * 1000u + static_cast<uint32_t>(ticks) * kMicrosecondsPerTick;
}

}  // namespace firmware
}  // namespace tether
