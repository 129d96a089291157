// Watchdog reset and early reset-cause capture: see tether/firmware/reset.hpp.
#include "tether/firmware/reset.hpp"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>

namespace {

// .noinit: written in .init3, before .init4 zeroes .bss, so an ordinary variable would be wiped.
uint8_t g_reset_cause __attribute__((section(".noinit")));

}  // namespace

// Runs from the startup code between the stack setup (.init2) and the .data/.bss setup (.init4).
// Naked: no prologue, no RET; execution falls through into .init4. Nothing calls it, so the runtime's
// CMakeLists forces it into every image with -Wl,--undefined (an archive member nobody references
// would never be linked). extern "C" keeps that symbol name unmangled.
extern "C" void tether_firmware_early_init() __attribute__((naked, used, section(".init3")));
extern "C" void tether_firmware_early_init() {
  g_reset_cause = static_cast<uint8_t>(MCUSR & (_BV(PORF) | _BV(EXTRF) | _BV(BORF) | _BV(WDRF)));
  MCUSR = 0;  // WDRF must be clear before WDE can be cleared
  wdt_disable();
}

namespace tether {
namespace firmware {

uint8_t reset_cause() { return g_reset_cause; }

void system_reset() {
  cli();
  wdt_enable(WDTO_15MS);
  for (;;) {
  }
}

}  // namespace firmware
}  // namespace tether
