// AVR back end of crc.hpp's CRC-8/SMBUS: two lookups in a 16-entry flash table per byte, about a
// third of avr-libc's bit loop (`_crc8_ccitt_update`, 8 shifts per byte) for 16 bytes of flash.
// Romi checks and writes one CRC per frame, Elcano generation D one per message.
#include <avr/pgmspace.h>

#include "tether/core/crc.hpp"

namespace tether {

namespace {

// kNibble[h]: the register (poly 0x07, MSB first) after shifting out the nibble h from its top four
// bits: the CRC of four bits is linear, so crc' = (crc << 4) ^ kNibble[crc >> 4].
const uint8_t kNibble[16] PROGMEM = {0x00, 0x07, 0x0e, 0x09, 0x1c, 0x1b, 0x12, 0x15,
                                     0x38, 0x3f, 0x36, 0x31, 0x24, 0x23, 0x2a, 0x2d};

// SWAP exchanges the nibbles in one cycle; avr-gcc -Os shifts by 4 in a loop, on 16 bits.
__attribute__((always_inline)) inline uint8_t crc8_nibble(uint8_t crc) {
  const uint8_t swapped = __builtin_avr_swap(crc);
  return static_cast<uint8_t>((swapped & 0xF0) ^ pgm_read_byte(&kNibble[swapped & 0x0F]));
}

__attribute__((always_inline)) inline uint8_t crc8_step(uint8_t crc, uint8_t byte) { return crc8_nibble(crc8_nibble(static_cast<uint8_t>(crc ^ byte))); }

}  // namespace

void Crc8Smbus::reset() { state_ = 0x00; }
void Crc8Smbus::update(uint8_t byte) { state_ = crc8_step(state_, byte); }
void Crc8Smbus::update(ByteView bytes) {
  for (uint8_t byte : bytes) state_ = crc8_step(state_, byte);
}
Crc8Smbus::Value Crc8Smbus::value() const { return state_; }

}  // namespace tether
