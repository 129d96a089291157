/// @file crc.hpp
/// The two checksums Tether's protocols use, behind one interface.
///
/// - `Crc8Smbus`: CRC-8/SMBUS (poly 0x07, init 0, no reflection, xorout 0; check 0xF4). Romi frames and
///   Elcano generation D.
/// - `Crc16Mcrf4xx`: CRC-16/MCRF4XX (poly 0x1021 reflected, init 0xFFFF, xorout 0; check 0x6F91). The
///   proxy protocol's frame check; the same as MAVLink's X.25 checksum.
///
/// Both have the same shape: construct (or `reset`), `update` with bytes in any chunking, read `value`;
/// or call the static `compute`. Back ends differ per platform. The AVR: a 256-entry flash table for
/// CRC-8 (a quarter of avr-libc's `_crc8_ccitt_update` bit loop) and avr-libc's hand-tuned
/// `_crc_ccitt_update` for CRC-16. The host: tables computed by Boost.CRC (`boost::crc_optimal`), taken
/// eight bytes per step ("slicing by 8", `detail::SlicedCrc`), all inline. `update(uint8_t)` is inline
/// on both so that a codec can fold the CRC into its own byte loop instead of a second pass.
///
/// Why slicing on the host: a byte-table CRC is one dependent table load per byte (~1.7 ns
/// here), which alone made a ~32-byte frame's encode + decode cost more than its 100 ns budget. Slicing
/// makes it one dependent load per eight bytes; bytes fed one at a time are held (at most seven) until
/// eight are there, so a codec's per-byte calls get the same speed as a run.
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
#else
namespace detail {

/// Host tables of a CRC whose register is `Value` and whose byte step is
/// `reg' = (reg >> 8) ^ row[0][(reg ^ byte) & 0xFF]` (a reflected CRC-16, or any CRC-8). Row `k`, entry
/// `b`: the register after the byte `b` and then `k` zero bytes, from a zero register, as Boost.CRC's
/// `Engine` (a `crc_optimal` with init and xorout 0, so its checksum is the register) computes it.
template <typename Engine, typename Value>
struct CrcSlices {
  /// Rows 0..7 as above (row 0 is Boost's byte table).
  Value row[8][256];

  /// The tables of `Engine`, built once (thread-safe) on first use.
  static const CrcSlices& get() {
    static const CrcSlices slices;
    return slices;
  }

 private:
  // Out of line and cold: inlined into a caller's byte loop, the construction's registers would push the
  // CRC register onto the stack on every byte.
  __attribute__((noinline, cold)) CrcSlices() {
    for (unsigned b = 0; b < 256; ++b) {
      const uint8_t bytes[8] = {static_cast<uint8_t>(b), 0, 0, 0, 0, 0, 0, 0};
      for (unsigned k = 0; k < 8; ++k) {
        Engine engine;
        engine.process_bytes(bytes, k + 1);
        row[k][b] = static_cast<Value>(engine.checksum());
      }
    }
  }
};

/// The host CRC: the register advances eight bytes per table step; bytes fed one at a time wait in a
/// small block until eight are there. `Init` is the register's initial value; xorout is 0.
template <typename Engine, typename Value, Value Init>
class SlicedCrc {
 public:
  /// Starts a new computation.
  SlicedCrc() { reset(); }
  /// Forgets all bytes fed so far.
  void reset() {
    state_ = Init;
    held_ = 0;
  }
  /// Feeds one byte: stored; every eighth byte advances the register by the whole block.
  __attribute__((always_inline)) void update(uint8_t byte) {
    block_[held_++] = byte;
    if (held_ == 8) {
      state_ = step8(state_, block_);
      held_ = 0;
    }
  }
  /// Feeds bytes: completes a held block, then eight bytes per step, and holds the rest.
  void update(ByteView bytes) {
    const uint8_t* in = bytes.data();
    size_t left = bytes.size();
    while (held_ != 0 && left != 0) {
      update(*in++);
      --left;
    }
    Value crc = state_;
    for (; left >= 8; left -= 8, in += 8) crc = step8(crc, in);
    state_ = crc;
    for (; left != 0; --left) block_[held_++] = *in++;
  }
  /// Checksum of all bytes fed since the last reset (the held bytes taken one by one).
  Value value() const {
    const Slices& t = Slices::get();
    Value crc = state_;
    for (uint8_t i = 0; i < held_; ++i) crc = static_cast<Value>((crc >> 8) ^ t.row[0][(crc ^ block_[i]) & 0xFF]);
    return crc;
  }

 private:
  using Slices = CrcSlices<Engine, Value>;

  // The register after the eight bytes at `in`: the register's bytes combine with the first ones (one
  // for a CRC-8, two for a CRC-16), and every byte's share comes from its row.
  static Value step8(Value crc, const uint8_t* in) {
    const Slices& t = Slices::get();
    // Byte by byte, not one 16-bit load: bytes fed one at a time were just stored one by one, and a wider
    // load of them would wait for the stores to retire instead of being forwarded.
    const unsigned reg = crc;
    const unsigned first = (reg ^ in[0]) & 0xFFu;
    const unsigned second = ((reg >> 8) ^ in[1]) & 0xFFu;
    return static_cast<Value>(t.row[7][first] ^ t.row[6][second] ^ t.row[5][in[2]] ^ t.row[4][in[3]] ^
                              t.row[3][in[4]] ^ t.row[2][in[5]] ^ t.row[1][in[6]] ^ t.row[0][in[7]]);
  }

  Value state_;
  uint8_t held_;     // bytes in block_ (0..7)
  uint8_t block_[8];
};

}  // namespace detail
#endif

/// CRC-8/SMBUS, incremental.
class Crc8Smbus {
 public:
  /// Width of the checksum value.
  using Value = uint8_t;
#if defined(__AVR__)
  /// Starts a new computation.
  Crc8Smbus() { reset(); }
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds one byte (inline, one flash lookup: a codec folds it into its own byte loop).
  __attribute__((always_inline)) void update(uint8_t byte) {
    state_ = pgm_read_byte(&detail::kCrc8SmbusTable[static_cast<uint8_t>(state_ ^ byte)]);
  }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
#else
  /// Forgets all bytes fed so far.
  void reset() { crc_.reset(); }
  /// Feeds one byte.
  void update(uint8_t byte) { crc_.update(byte); }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes) { crc_.update(bytes); }
  /// Checksum of all bytes fed since the last reset.
  Value value() const { return crc_.value(); }
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
  detail::SlicedCrc<boost::crc_optimal<8, 0x07, 0x00, 0x00, false, false>, uint8_t, 0x00> crc_;
#endif
};

/// CRC-16/MCRF4XX, incremental.
class Crc16Mcrf4xx {
 public:
  /// Width of the checksum value.
  using Value = uint16_t;
  /// Feeds one byte (always inline: the per-byte step of codecs' byte loops; -Os would outline it).
  __attribute__((always_inline)) void update(uint8_t byte) {
#if defined(__AVR__)
    state_ = _crc_ccitt_update(state_, byte);
#else
    crc_.update(byte);
#endif
  }
#if defined(__AVR__)
  /// Starts a new computation.
  Crc16Mcrf4xx() { reset(); }
  /// Forgets all bytes fed so far.
  void reset();
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes);
  /// Checksum of all bytes fed since the last reset.
  Value value() const;
#else
  /// Forgets all bytes fed so far.
  void reset() { crc_.reset(); }
  /// Feeds bytes; any chunking gives the same result.
  void update(ByteView bytes) { crc_.update(bytes); }
  /// Checksum of all bytes fed since the last reset.
  Value value() const { return crc_.value(); }
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
  // Reflected in and out: the register is kept reflected, so its low byte meets the next input byte.
  detail::SlicedCrc<boost::crc_optimal<16, 0x1021, 0x0000, 0x0000, true, true>, uint16_t, 0xFFFF> crc_;
#endif
};

/// Name of the back end compiled in ("boost" or "avr-libc"), for diagnostics and benchmarks.
const char* crc_backend_name();

}  // namespace tether
