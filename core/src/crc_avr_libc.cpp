// AVR back end of crc.hpp: avr-libc's util/crc16.h. `_crc8_ccitt_update` is CRC-8 with poly 0x07,
// MSB first (= SMBUS from init 0); `_crc_ccitt_update` is the reflected 0x1021 CRC (= MCRF4XX from 0xFFFF).
#include <util/crc16.h>

#include "tether/core/crc.hpp"

namespace tether {

void Crc8Smbus::reset() { state_ = 0x00; }
void Crc8Smbus::update(uint8_t byte) { state_ = _crc8_ccitt_update(state_, byte); }
void Crc8Smbus::update(ByteView bytes) {
  uint8_t state = state_;  // in a register: the member would be loaded and stored for every byte
  for (uint8_t byte : bytes) state = _crc8_ccitt_update(state, byte);
  state_ = state;
}
Crc8Smbus::Value Crc8Smbus::value() const { return state_; }

void Crc16Mcrf4xx::reset() { state_ = 0xFFFF; }
void Crc16Mcrf4xx::update(ByteView bytes) {
  uint16_t state = state_;  // in registers: the member would be loaded and stored for every byte
  for (uint8_t byte : bytes) state = _crc_ccitt_update(state, byte);
  state_ = state;
}
Crc16Mcrf4xx::Value Crc16Mcrf4xx::value() const { return state_; }

const char* crc_backend_name() { return "avr-libc"; }

}  // namespace tether
