/// @file session_id.hpp
/// The sessionId of a boot: new at every boot, never 0, never the previous boot's.
///
/// The host stores the sessionId of ResetEvent and compares every ArduinoInfo against it: a different id
/// means the device reset behind its back. So the one hard requirement is that two CONSECUTIVE boots
/// never show the same id -- also in the simulator, where a watchdog reset keeps SRAM and nothing is
/// random. Randomness on top protects against ids repeating across boards and re-flashed boards.
///
/// ## Entropy sources (`boot_session_id`, src/session_id_avr.cpp)
///   1. A boot counter in EEPROM, incremented at every boot (`kBootCounterAddress`). It changes the hash
///      input at every boot, including in simavr, whose EEPROM persists across resets and power cycles.
///   2. The previous boot's id, also in EEPROM (`kPreviousIdAddress`): the derived id is checked against
///      it and nudged if equal (see `derive_session_id`), which makes "differs from the previous boot" a
///      guarantee rather than a probability.
///   3. Uninitialised SRAM: every byte between the end of the static data (`__heap_start`, after .bss and
///      .noinit) and the stack, ~1.2 KB, plus a 16-byte `.noinit` carry that each boot leaves behind.
///      On a real ATmega328P, SRAM powers up in a pattern that is partly device-specific and partly noisy
///      cell by cell (several percent of the bits flip between power-ups); the virtual Uno fills SRAM with
///      seeded noise on a power cycle. After a warm reset (watchdog, RESET pin) SRAM holds what the
///      previous run left there (its stack, its carry), which differs run to run on real hardware.
///   4. ADC noise: 16 conversions of the internal temperature sensor against the 1.1 V reference; the low
///      bits of each reading wander by a count or two on real silicon (the simulator returns constants).
///   5. The reset cause (MCUSR as saved by the runtime).
/// The bytes go through a 32-bit FNV-1a pool, and the result through the MurmurHash3 finaliser mixed with
/// the counter. Costs at boot, before interrupts are enabled: ~5 ms of hashing, ~2 ms of ADC, and EEPROM
/// writes of the bytes that changed (eeprom_update: typically 5 bytes, ~17 ms on the part; EEPROM cells
/// last 100,000 writes, so ~100k boots). The ADC is switched off again afterwards.
///
/// EEPROM use: the last 8 bytes (0x3F8..0x3FF on the ATmega328P); applications must not use them.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"

namespace tether {
namespace proxy {
namespace device {

/// EEPROM address of the boot counter (uint32, little-endian): the last 8 bytes of a 1 KB EEPROM.
constexpr uint16_t kBootCounterAddress = 0x3F8;
/// EEPROM address of the previous boot's sessionId (uint32).
constexpr uint16_t kPreviousIdAddress = 0x3FC;

/// A 32-bit FNV-1a accumulator: cheap on the AVR and every input byte changes the state.
class EntropyPool {
 public:
  /// Adds one byte.
  void add(uint8_t byte);
  /// Adds the four bytes of `value` (little-endian).
  void add_word(uint32_t value);
  /// Adds bytes.
  void add(ByteView bytes);
  /// The pool's state.
  uint32_t value() const { return state_; }

 private:
  uint32_t state_ = 2166136261u;  // FNV offset basis
};

/// MurmurHash3's 32-bit finaliser: a bijection that spreads every input bit over the output.
uint32_t mix32(uint32_t x);

/// The sessionId of a boot from its boot counter, the entropy pool's value and the previous boot's id:
/// `mix32(entropy ^ mix32(boot_count ^ 0x9E3779B9))`, except that it is never 0 and never `previous`:
/// if the hash hits either, the id becomes `previous + 1` (or 1 when that wraps to 0).
uint32_t derive_session_id(uint32_t boot_count, uint32_t entropy, uint32_t previous);

/// Gathers the entropy above, derives this boot's id and records counter and id in EEPROM. Call once,
/// first thing in `main`, before interrupts are enabled (it reads free SRAM up to the stack). AVR only
/// (src/session_id_avr.cpp).
uint32_t boot_session_id();

}  // namespace device
}  // namespace proxy
}  // namespace tether
