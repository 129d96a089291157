/// @file crc.hpp
/// The two checksums Tether's protocols use, behind one interface.
///
/// - `Crc8Smbus`: CRC-8/SMBUS (poly 0x07, init 0, no reflection, xorout 0; check 0xF4). Romi frames and
///   Elcano generation D.
/// - `Crc16Mcrf4xx`: CRC-16/MCRF4XX (poly 0x1021 reflected, init 0xFFFF, xorout 0; check 0x6F91). The
///   proxy protocol's frame check; the same as MAVLink's X.25 checksum.
///
/// Both have the same shape: construct (or `reset`), `update` with bytes in any chunking, read `value`;
/// or call the static `compute`. Back ends differ per platform: the host uses Boost.CRC
/// (`boost::crc_optimal`, table driven), the AVR a 256-entry flash table for CRC-8 (a quarter of avr-libc's
/// `_crc8_ccitt_update` bit loop) and avr-libc's hand-tuned `_crc_ccitt_update` for CRC-16. The register
/// kept between updates is back-end private. `Crc16Mcrf4xx::update(uint8_t)` is inline (both back ends
/// are headers) so that a codec can fold the CRC into its own byte loop, with the register in a CPU
/// register, instead of a second pass (issue 17).
#pragma once

#include <stdint.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#include <util/crc16.h>
// avr-libc's step is 17 instructions of inline asm; under -Os the compiler otherwise makes it a function
// called per byte (call, ret and register moves: +~12 cycles a byte). This redeclaration only adds the attribute.
static __inline__ uint16_t _crc_ccitt_update(uint16_t crc, uint8_t data) __attribute__((always_inline));
#else
#include <boost/crc.hpp>
#endif

#include "tether/core/bytes.hpp"

namespace tether {

#if defined(__AVR__)
namespace detail {
/// CRC-8/SMBUS by whole bytes: entry i is the register after shifting byte i through it (src/crc8_avr.cpp).
extern const uint8_t kCrc8SmbusTable[256] PROGMEM;
}  // namespace detail
#endif

/// CRC-8/SMBUS, incremental.
class Crc8Smbus {
 public:
  /// Width of the checksum value.
  using Value = uint8_t;
  /// Starts a new computation.
  Crc8Smbus() { reset(); }
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds one byte (inline on the AVR, one flash lookup: a codec folds it into its own byte loop).
#if defined(__AVR__)
  __attribute__((always_inline)) void update(uint8_t byte) {
    state_ = pgm_read_byte(&detail::kCrc8SmbusTable[static_cast<uint8_t>(state_ ^ byte)]);
  }
#else
  void update(uint8_t byte);
#endif
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
  /// Checksum of `bytes` in one call.
  static Value compute(ByteView bytes) {
    Crc8Smbus crc;
    crc.update(bytes);
    return crc.value();
  }

 private:
  uint8_t state_;
};

/// CRC-16/MCRF4XX, incremental.
class Crc16Mcrf4xx {
 public:
  /// Width of the checksum value.
  using Value = uint16_t;
  /// Starts a new computation.
  Crc16Mcrf4xx() { reset(); }
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds one byte (always inline: the per-byte step of codecs' byte loops; -Os would outline it).
  __attribute__((always_inline)) void update(uint8_t byte) {
#if defined(__AVR__)
    state_ = _crc_ccitt_update(state_, byte);
#else
    engine_.process_byte(byte);
#endif
  }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
  /// Checksum of `bytes` in one call.
  static Value compute(ByteView bytes) {
    Crc16Mcrf4xx crc;
    crc.update(bytes);
    return crc.value();
  }

 private:
#if defined(__AVR__)
  uint16_t state_;
#else
  // Boost's engine itself: it keeps its register reflected, so a per-byte step is one table lookup.
  boost::crc_optimal<16, 0x1021, 0xFFFF, 0x0000, true, true> engine_;
#endif
};

/// Name of the back end compiled in ("boost" or "avr-libc"), for diagnostics and benchmarks.
const char* crc_backend_name();

}  // namespace tether
