/// @file power.hpp
/// Sleeping while there is nothing to do.
///
/// `idle<Uart>()` puts the CPU in IDLE sleep (timers and UART keep running) until the next interrupt:
/// a received byte, a sent byte, the 1 ms tick. It checks for pending RX bytes with interrupts
/// disabled and enables them in the instruction before SLEEP, so a byte arriving between the check and
/// the sleep still wakes it (SEI takes effect one instruction late, after SLEEP has started).
/// `idle_unless(condition)` is the same with the caller's own "work pending" test.
///
/// Call it at the bottom of the main loop when the loop found no work. Besides saving power, it makes
/// simulators fast: simavr skips the sleeping cycles instead of executing a busy loop.
#pragma once

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

namespace tether {
namespace firmware {

/// Selects IDLE as the sleep mode (SM2..SM0 = 000). avr-libc's set_sleep_mode() trips -Wconversion.
inline void select_idle_sleep_mode() {
  SMCR = static_cast<uint8_t>(SMCR & ~(_BV(SM2) | _BV(SM1) | _BV(SM0)));
}

/// Sleeps in IDLE mode until an interrupt has run, unless `work_pending()` returns true; it is called
/// with interrupts disabled, so what it reads cannot change before the sleep starts except through an
/// interrupt, which then ends the sleep. Returns with interrupts enabled. SMCR is written whole (IDLE
/// with SE, then 0: the runtime owns it), one OUT each rather than three read-modify-writes per wake.
template <typename Condition>
void idle_unless(Condition work_pending) {
  cli();
  if (!work_pending()) {
    SMCR = _BV(SE);  // IDLE (SM2..SM0 = 000), sleep enabled
    sei();
    sleep_cpu();
    SMCR = 0;
  }
  sei();
}

/// Sleeps in IDLE mode until an interrupt has run, unless `Uart` (a `Uart0<...>`) holds unread bytes,
/// in which case it returns at once. Returns with interrupts enabled.
template <typename Uart>
void idle() {
  idle_unless([] { return Uart::available() != 0; });
}

}  // namespace firmware
}  // namespace tether
