// Fuzz target of the Romi envelope decoder and request parser, as a device and as a host would use them.
// Invariants: no crash or sanitizer finding; payload views stay inside the decoder; a decoded request
// payload re-encoded with its id decodes to the same payload and id; parse results are within limits.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "tether/romi/encoder.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/request_parser.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::romi;

template <size_t Capacity>
void decode_all(const uint8_t* data, size_t size) {
  LinkCounters counters;
  Decoder<Capacity> decoder(counters);
  ByteView rest(data, size);
  while (!rest.empty()) {  // span feeding: stops at each frame or error
    const FeedResult fed = decoder.feed(rest);
    TETHER_FUZZ_CHECK(fed.consumed >= 1 && fed.consumed <= rest.size());
    rest = rest.subview(fed.consumed);
    if (fed.status != DecodeStatus::frame) continue;
    const Frame& event = decoder.frame();
    TETHER_FUZZ_CHECK(event.payload.size() <= Capacity);
    if (event.log) continue;
    Request request;
    if (parse_request(event.payload, request) == Error::no_error) {
      TETHER_FUZZ_CHECK(request.argument_count <= kMaxArguments);
      TETHER_FUZZ_CHECK(std::strlen(request.string) <= kMaxStringLength);
      // The device's form: its string is a view of the payload, between quotes, equal to the copy.
      ParsedRequest parsed;
      TETHER_FUZZ_CHECK(parse_request(event.payload, parsed) == Error::no_error);
      const ByteView string = parsed.string_view;
      TETHER_FUZZ_CHECK(parsed.has_string == request.has_string && string.size() <= kMaxStringLength);
      TETHER_FUZZ_CHECK(std::strlen(request.string) == string.size());
      TETHER_FUZZ_CHECK(string.empty() || std::memcmp(request.string, string.data(), string.size()) == 0);
      if (parsed.has_string) {
        TETHER_FUZZ_CHECK(string.data() > event.payload.data() && string.end() < event.payload.end());
        TETHER_FUZZ_CHECK(string.data()[-1] == '"' && *string.end() == '"');
      }
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
    Decoder<Capacity> again(again_counters);
    bool seen = false;
    for (size_t j = 0; j < encoded.value(); ++j) {
      const DecodeStatus status = again.feed(frame[j]);
      if (status == DecodeStatus::more) continue;
      TETHER_FUZZ_CHECK(status == DecodeStatus::frame && !again.frame().log);
      const Frame& e = again.frame();
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
  if (validate_request_payload(ByteView(data, size)) == Error::no_error) {
    Request request;
    TETHER_FUZZ_CHECK(parse_request(ByteView(data, size), request) == Error::no_error);
    TETHER_FUZZ_CHECK(size <= kMaxHostPayload);
  }
  return 0;
}
