// AVR back end of crc.hpp's CRC-16: avr-libc's util/crc16.h. `_crc_ccitt_update` is the reflected
// 0x1021 CRC (= MCRF4XX from 0xFFFF). CRC-8 is in crc8_avr.cpp.
#include <util/crc16.h>

#include "tether/core/crc.hpp"

namespace tether {

void Crc16Mcrf4xx::reset() { state_ = 0xFFFF; }
void Crc16Mcrf4xx::update(ByteView bytes) {
  uint16_t state = state_;  // in registers: the member would be loaded and stored for every byte
  for (uint8_t byte : bytes) state = _crc_ccitt_update(state, byte);
  state_ = state;
}
Crc16Mcrf4xx::Value Crc16Mcrf4xx::value() const { return state_; }

const char* crc_backend_name() { return "avr-libc"; }

}  // namespace tether
