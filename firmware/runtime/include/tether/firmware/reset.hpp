/// @file reset.hpp
/// Software reset through the watchdog, and why the MCU last reset.
///
/// `system_reset()` is a real reset (every peripheral back to its reset state), not a jump to 0: it
/// arms the watchdog at 15 ms and waits. After a watchdog reset the watchdog stays armed at its
/// shortest period, so the runtime disarms it in `.init3` -- before static initialisation and `main`,
/// which would otherwise never get far enough to do it and the board would reset forever. The same
/// early code saves MCUSR (and clears it, so the next reset reports only its own cause). Linking
/// `tether_firmware_runtime` always brings that code in.
///
/// On a board whose bootloader clears MCUSR before starting the application (the optiboot of a stock
/// Uno does), `reset_cause()` reads 0 after resets that went through the bootloader.
#pragma once

#include <avr/io.h>
#include <stdint.h>

namespace tether {
namespace firmware {

/// `reset_cause()` bit: power-on.
constexpr uint8_t kResetPowerOn = _BV(PORF);
/// `reset_cause()` bit: the RESET pin (on an Uno: the button, or DTR when a host opens the port).
constexpr uint8_t kResetExternal = _BV(EXTRF);
/// `reset_cause()` bit: supply dipped below the brown-out level.
constexpr uint8_t kResetBrownOut = _BV(BORF);
/// `reset_cause()` bit: watchdog timeout, which includes `system_reset()`.
constexpr uint8_t kResetWatchdog = _BV(WDRF);

/// MCUSR as it was at the last reset: a mask of the kReset* bits (0 if a bootloader cleared it).
uint8_t reset_cause();

/// Resets the MCU through the watchdog within ~15 ms; never returns. Interrupts are disabled first, so
/// queued UART output is lost: `flush()` the UART before calling it if the bytes matter.
[[noreturn]] void system_reset();

}  // namespace firmware
}  // namespace tether
