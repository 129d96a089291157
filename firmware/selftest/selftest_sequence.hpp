/// @file selftest_sequence.hpp
/// The pseudo-random buffers the AVR selftest checksums, shared by the firmware and the host test that
/// recomputes them with the host CRC back end. Portable (stdint only).
#pragma once

#include <stdint.h>

namespace tether {
namespace selftest {

/// Number of random buffers the selftest checksums.
constexpr uint8_t kBufferCount = 48;
/// Largest random buffer, in bytes.
constexpr uint16_t kMaxBufferLength = 300;
/// Seed used when the EEPROM holds none (erased: 0xFFFFFFFF).
constexpr uint32_t kDefaultSeed = 0x2545F491u;

/// Marsaglia's xorshift32; never yields 0 from a non-zero state.
class Xorshift32 {
 public:
  /// Generator from `seed` (0 and the erased-EEPROM value map to the default seed).
  explicit Xorshift32(uint32_t seed) : state_(seed == 0 || seed == 0xFFFFFFFFu ? kDefaultSeed : seed) {}
  /// Next 32-bit value.
  uint32_t next() {
    state_ ^= state_ << 13;
    state_ ^= state_ >> 17;
    state_ ^= state_ << 5;
    return state_;
  }
  /// Length of the next buffer, 0..kMaxBufferLength.
  uint16_t next_length() { return static_cast<uint16_t>(next() % (kMaxBufferLength + 1u)); }
  /// Next buffer byte.
  uint8_t next_byte() { return static_cast<uint8_t>(next() >> 24); }

 private:
  uint32_t state_;
};

}  // namespace selftest
}  // namespace tether
