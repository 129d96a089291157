// Host back end of crc.hpp: Boost.CRC. The register kept between updates is Boost's interim remainder,
// which `reset(rem)` and `get_interim_remainder()` round-trip by contract.
#include <boost/crc.hpp>

#include "tether/core/crc.hpp"

namespace tether {
namespace {
using Crc8Engine = boost::crc_optimal<8, 0x07, 0x00, 0x00, false, false>;
using Crc16Engine = boost::crc_optimal<16, 0x1021, 0xFFFF, 0x0000, true, true>;
}  // namespace

void Crc8Smbus::reset() { state_ = Crc8Engine().get_interim_remainder(); }
void Crc8Smbus::update(uint8_t byte) { update(ByteView(&byte, 1)); }
void Crc8Smbus::update(ByteView bytes) {
  Crc8Engine engine(state_);
  engine.process_bytes(bytes.data(), bytes.size());
  state_ = engine.get_interim_remainder();
}
Crc8Smbus::Value Crc8Smbus::value() const { return Crc8Engine(state_).checksum(); }

void Crc16Mcrf4xx::reset() { state_ = Crc16Engine().get_interim_remainder(); }
void Crc16Mcrf4xx::update(uint8_t byte) { update(ByteView(&byte, 1)); }
void Crc16Mcrf4xx::update(ByteView bytes) {
  Crc16Engine engine(state_);
  engine.process_bytes(bytes.data(), bytes.size());
  state_ = engine.get_interim_remainder();
}
Crc16Mcrf4xx::Value Crc16Mcrf4xx::value() const { return Crc16Engine(state_).checksum(); }

const char* crc_backend_name() { return "boost"; }

}  // namespace tether
