// Portable half of the sessionId: the entropy pool and the derivation (tether/proxy/device/session_id.hpp).
// Out of line on purpose: each 32-bit multiply is a libgcc call on the AVR, one copy is enough.
#include "tether/proxy/device/session_id.hpp"

namespace tether {
namespace proxy {
namespace device {

// Out of line: a 32-bit multiply is a library call with its own register setup, inlined at each of the
// boot code's many call sites it cost flash (the boot runs once; the call costs nothing that matters).
__attribute__((noinline)) void EntropyPool::add(uint8_t byte) { state_ = (state_ ^ byte) * 16777619u; }  // FNV prime

void EntropyPool::add_word(uint32_t value) {
  for (uint8_t i = 0; i < 4; ++i) add(static_cast<uint8_t>(value >> (8u * i)));
}

void EntropyPool::add(ByteView bytes) {
  for (size_t i = 0; i < bytes.size(); ++i) add(bytes[i]);
}

// Out of line: two 32-bit multiplies (libgcc calls); the boot derives two, one copy is enough.
__attribute__((noinline)) uint32_t mix32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x85EBCA6Bu;
  x ^= x >> 13;
  x *= 0xC2B2AE35u;
  x ^= x >> 16;
  return x;
}

uint32_t derive_session_id(uint32_t boot_count, uint32_t entropy, uint32_t previous) {
  uint32_t id = mix32(entropy ^ mix32(boot_count ^ 0x9E3779B9u));
  if (id == 0 || id == previous) {
    id = previous + 1u;
    if (id == 0) id = 1;
  }
  return id;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
