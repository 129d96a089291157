// Portability gate, part 2: explicit instantiations of every session-engine template with the
// parameters the codecs use, so avr-gcc compiles every member function, not only the ones a firmware
// happens to call. A change that needs the STL, heap or exceptions fails here.
#include <stdint.h>

#include "tether/core/session/duplicate_filter.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/core/session/session_monitor.hpp"
#include "tether/core/session/write_pacer.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/elcano/session_policy.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/session_policy.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/limits.hpp"

namespace tether {
namespace portability {

/// Reply policy with 8-bit ids and int16 codes (Romi's shape).
struct ByteIdPolicy {
  using Id = uint8_t;
  using Code = int16_t;
  static bool is_success(Code code) { return code >= 0; }
  static bool is_retryable(Code code) { return code < 0 && code >= -6; }
};
/// Reply policy with 32-bit ids (the proxy protocol's shape).
struct WordIdPolicy {
  using Id = uint32_t;
  using Code = uint8_t;
  static bool is_success(Code) { return true; }
  static bool is_retryable(Code) { return false; }
};

}  // namespace portability

template class session::RequestTable<portability::ByteIdPolicy, 1>;
template class session::RequestTable<portability::WordIdPolicy, 4>;
template class session::SessionMonitor<uint32_t, 8>;
template class session::DuplicateFilter<uint8_t, 1, 64>;
template class session::DuplicateFilter<uint32_t, 8, 0>;
template class romi::Decoder<romi::kDeviceDecoderCapacity>;
template class proxy::Decoder<64>;
template class proxy::CobsDecoder<66>;
template class elcano::Decoder<96>;
template class elcano::RingNode<96, 256, 4>;
template class elcano::RingNode<48, 128, 8>;
template class session::RequestTable<elcano::SessionPolicy, 4>;
template class session::RequestTable<proxy::SessionPolicy, proxy::kMaxInFlight>;

}  // namespace tether
