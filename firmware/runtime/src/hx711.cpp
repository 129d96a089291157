// HX711 load-cell reader; see hx711.hpp.
#include "tether/firmware/hx711.hpp"

#include <util/atomic.h>

#include "tether/firmware/pin_registers.hpp"

namespace tether {
namespace firmware {
namespace hx711 {

void begin(uint8_t dout_pin, uint8_t sck_pin) {
  const PinRegisters sck = pin_registers(sck_pin);
  const PinRegisters dout = pin_registers(dout_pin);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    write_bits(sck.port, sck.mask, false);
    write_bits(sck.ddr, sck.mask, true);
    write_bits(dout.ddr, dout.mask, false);
    write_bits(dout.port, dout.mask, false);
  }
}

bool read(uint8_t dout_pin, uint8_t sck_pin, uint32_t& value) {
  const PinRegisters sck = pin_registers(sck_pin);
  const PinRegisters dout = pin_registers(dout_pin);
  if ((*dout.in & dout.mask) != 0) return false;  // converting
  uint32_t bits = 0;
  for (uint8_t pulse = 0; pulse < 25; ++pulse) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      write_bits(sck.port, sck.mask, true);
      write_bits(sck.port, sck.mask, false);
    }
    if (pulse < 24) bits = (bits << 1) | ((*dout.in & dout.mask) != 0 ? 1u : 0u);
  }
  if ((bits & 0x800000u) != 0) bits |= 0xFF000000u;
  value = bits;
  return true;
}

}  // namespace hx711
}  // namespace firmware
}  // namespace tether
