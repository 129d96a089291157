// Fuzz target of the device's message codec (message_codec.hpp): the input decoded as each message of the
// codec test schema (codecs/rpc/device/tests/schemas/codec.proto: every field kind) by the codec and by
// nanopb 0.4, and as the envelope (envelope.hpp's hand-written HostMessage decoder). Invariants: the same
// outcome; when accepted, the same struct, and the same bytes (or the same refusal) when encoded back with
// room and with too little room (the first byte's worth).
#include <cstddef>
#include <cstdint>

#include "codec_check.hpp"
#include "tether/testing/fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::size_t short_capacity = size == 0 ? 0 : data[0] % 96;
  const codec_check::Difference d = codec_check::compare_all(data, size, short_capacity);
  if (d) std::fprintf(stderr, "%s\n", d.what.c_str());
  TETHER_FUZZ_CHECK(!d);
  return 0;
}
