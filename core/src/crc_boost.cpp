// Host back end of crc.hpp: Boost.CRC. The CRC-8 register kept between updates is Boost's interim
// remainder, which `reset(rem)` and `get_interim_remainder()` round-trip by contract; CRC-16 keeps the engine.
#include <boost/crc.hpp>

#include "tether/core/crc.hpp"

namespace tether {
namespace {
using Crc8Engine = boost::crc_optimal<8, 0x07, 0x00, 0x00, false, false>;
}  // namespace

void Crc8Smbus::reset() { state_ = Crc8Engine().get_interim_remainder(); }
void Crc8Smbus::update(uint8_t byte) { update(ByteView(&byte, 1)); }
void Crc8Smbus::update(ByteView bytes) {
  Crc8Engine engine(state_);
  engine.process_bytes(bytes.data(), bytes.size());
  state_ = engine.get_interim_remainder();
}
Crc8Smbus::Value Crc8Smbus::value() const { return Crc8Engine(state_).checksum(); }

void Crc16Mcrf4xx::reset() { engine_.reset(); }
void Crc16Mcrf4xx::update(ByteView bytes) { engine_.process_bytes(bytes.data(), bytes.size()); }
Crc16Mcrf4xx::Value Crc16Mcrf4xx::value() const { return static_cast<Value>(engine_.checksum()); }

const char* crc_backend_name() { return "boost"; }

}  // namespace tether
