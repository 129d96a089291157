// Fuzz target of the Romi envelope decoder and request parser, as a device and as a host would use them.
// Invariants: no crash or sanitizer finding; payload views stay inside the decoder; a decoded request
// payload re-encoded with its id decodes to the same payload and id; parse results are within limits.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "tether/romi/encoder.hpp"
#include "tether/romi/envelope_decoder.hpp"
#include "tether/romi/request_parser.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::romi;

template <size_t Capacity>
void decode_all(const uint8_t* data, size_t size) {
  LinkCounters counters;
  EnvelopeDecoder<Capacity> decoder(counters);
  for (size_t i = 0; i < size; ++i) {
    const EnvelopeEvent event = decoder.feed(data[i]);
    if (event.kind == EnvelopeEvent::Kind::none || event.kind == EnvelopeEvent::Kind::error) continue;
    TETHER_FUZZ_CHECK(event.payload.size() <= Capacity);
    if (event.kind != EnvelopeEvent::Kind::frame) continue;
    Request request;
    if (parse_request(event.payload, request) == ErrorCode::no_error) {
      TETHER_FUZZ_CHECK(request.argument_count <= kMaxArguments);
      TETHER_FUZZ_CHECK(std::strlen(request.string) <= kMaxStringLength);
    }
    if (event.manual) continue;
    // Round trip: the same payload and id, framed by the encoder, decodes to the same frame.
    uint8_t frame[Capacity + 16];
    const auto encoded = encode_request(event.payload, event.id, frame);
    TETHER_FUZZ_CHECK(encoded.ok());
    uint8_t copy[Capacity];
    const size_t payload_size = event.payload.size();
    std::memcpy(copy, event.payload.data(), payload_size);
    LinkCounters again_counters;
    EnvelopeDecoder<Capacity> again(again_counters);
    bool seen = false;
    for (size_t j = 0; j < encoded.value(); ++j) {
      const EnvelopeEvent e = again.feed(frame[j]);
      if (e.kind == EnvelopeEvent::Kind::none) continue;
      TETHER_FUZZ_CHECK(e.kind == EnvelopeEvent::Kind::frame);
      TETHER_FUZZ_CHECK(e.id == event.id && e.payload.size() == payload_size);
      TETHER_FUZZ_CHECK(std::memcmp(e.payload.data(), copy, payload_size) == 0);
      seen = true;
    }
    TETHER_FUZZ_CHECK(seen);
  }
  TETHER_FUZZ_CHECK(counters.frames_ok <= size / 6);  // a frame needs at least "#?:xxxx" minus one
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  decode_all<kDeviceDecoderCapacity>(data, size);
  decode_all<kHostDecoderCapacity>(data, size);
  // The host's validator must never accept what the device's parser rejects.
  if (validate_request_payload(ByteView(data, size)) == ErrorCode::no_error) {
    Request request;
    TETHER_FUZZ_CHECK(parse_request(ByteView(data, size), request) == ErrorCode::no_error);
    TETHER_FUZZ_CHECK(size <= kMaxHostPayload);
  }
  return 0;
}
