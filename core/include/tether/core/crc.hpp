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
/// (`boost::crc_optimal`, table driven), the AVR a 16-entry flash table for CRC-8 (a third of avr-libc's
/// `_crc8_ccitt_update` bit loop) and avr-libc's hand-tuned `_crc_ccitt_update` for CRC-16. The register
/// kept between updates is back-end private. `Crc16Mcrf4xx::update(uint8_t)` is inline (both back ends
/// are headers) so that a codec can fold the CRC into its own byte loop, with the register in a CPU
/// register, instead of a second pass (issue 17). On the host every operation of both is inline: the
/// object is Boost's engine itself, so a codec's per-byte call is one table step in its own loop and a
/// run of bytes is one `process_bytes` loop, with no call per byte or per run (issue 17: the out-of-line
/// CRC-8 call was half of a Romi frame's host cost).
#pragma once

#include <stdint.h>

#if defined(__AVR__)
#include <util/crc16.h>
// avr-libc's step is 17 instructions of inline asm; under -Os the compiler otherwise makes it a function
// called per byte (call, ret and register moves: +~12 cycles a byte). This redeclaration only adds the attribute.
static __inline__ uint16_t _crc_ccitt_update(uint16_t crc, uint8_t data) __attribute__((always_inline));
#else
#include <boost/crc.hpp>
#endif

#include "tether/core/bytes.hpp"

namespace tether {

/// CRC-8/SMBUS, incremental.
class Crc8Smbus {
 public:
  /// Width of the checksum value.
  using Value = uint8_t;
  /// Starts a new computation.
  Crc8Smbus() { reset(); }
#if defined(__AVR__)
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds one byte.
  void update(uint8_t byte);
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
#else
  /// Forgets all bytes fed so far.
  void reset() { engine_.reset(); }
  /// Feeds one byte.
  void update(uint8_t byte) { engine_.process_byte(byte); }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes) { engine_.process_bytes(bytes.data(), bytes.size()); }
  /// Checksum of all bytes fed since the last reset.
  Value value() const { return static_cast<Value>(engine_.checksum()); }
#endif
  /// Checksum of `bytes` in one call.
  static Value compute(ByteView bytes) {
    Crc8Smbus crc;
    crc.update(bytes);
    return crc.value();
  }

 private:
#if defined(__AVR__)
  uint8_t state_;
#else
  boost::crc_optimal<8, 0x07, 0x00, 0x00, false, false> engine_;
#endif
};

/// CRC-16/MCRF4XX, incremental.
class Crc16Mcrf4xx {
 public:
  /// Width of the checksum value.
  using Value = uint16_t;
  /// Starts a new computation.
  Crc16Mcrf4xx() { reset(); }
  /// Feeds one byte (always inline: the per-byte step of codecs' byte loops; -Os would outline it).
  __attribute__((always_inline)) void update(uint8_t byte) {
#if defined(__AVR__)
    state_ = _crc_ccitt_update(state_, byte);
#else
    engine_.process_byte(byte);
#endif
  }
#if defined(__AVR__)
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
#else
  /// Forgets all bytes fed so far.
  void reset() { engine_.reset(); }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes) { engine_.process_bytes(bytes.data(), bytes.size()); }
  /// Checksum of all bytes fed since the last reset.
  Value value() const { return static_cast<Value>(engine_.checksum()); }
#endif
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
