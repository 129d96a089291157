// Fuzz target of the Elcano reader (both generations). Invariants: no crash; span feeding (its own loop
// over the bytes inside a message) reports exactly what byte-at-a-time feeding does: the same events at
// the same bytes, the same messages, forwards, errors and counters; forwarded bytes stay within the reader; writing what was read, reading that and writing again gives the same bytes. (The reader,
// like the reference, accepts attributes a type does not carry, `D{s 1}{a 2}{b 3}`; the writer writes
// only the type's own, so fields are not compared one by one. Nodes forward the original bytes anyway.)
#include <cstddef>
#include <cstdint>
#include <initializer_list>

#include "tether/elcano/encoder.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/testing/fuzz_target.hpp"

using namespace tether;
using namespace tether::elcano;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const Generation generation : {Generation::b, Generation::d}) {
    LinkCounters counters;
    Decoder<> reader(generation, counters);
    LinkCounters single_counters;
    Decoder<> single(generation, single_counters);  // the same bytes one at a time
    ByteView rest(data, size);
    while (!rest.empty()) {  // span feeding: stops at each message or error
      const FeedResult fed = reader.feed(rest);
      TETHER_FUZZ_CHECK(fed.consumed >= 1 && fed.consumed <= rest.size());
      TETHER_FUZZ_CHECK(fed.status != DecodeStatus::more || fed.consumed == rest.size());
      for (size_t i = 0; i < fed.consumed; ++i) {
        const DecodeStatus one = single.feed(rest[i]);
        TETHER_FUZZ_CHECK(one == (i + 1 == fed.consumed ? fed.status : DecodeStatus::more));
      }
      TETHER_FUZZ_CHECK(counters.frames_ok == single_counters.frames_ok &&
                        counters.crc_errors == single_counters.crc_errors &&
                        counters.framing_errors == single_counters.framing_errors &&
                        counters.oversize_frames == single_counters.oversize_frames &&
                        counters.resyncs == single_counters.resyncs);
      TETHER_FUZZ_CHECK(reader.in_frame() == single.in_frame());
      if (fed.status == DecodeStatus::error) TETHER_FUZZ_CHECK(reader.error() == single.error());
      if (fed.status == DecodeStatus::frame) {
        TETHER_FUZZ_CHECK(reader.frame() == single.frame());
        TETHER_FUZZ_CHECK(reader.forward().equals(single.forward()));
      }
      rest = rest.subview(fed.consumed);
      if (fed.status != DecodeStatus::frame) continue;
      TETHER_FUZZ_CHECK(reader.forward().size() <= 96);
      TETHER_FUZZ_CHECK(has_required_fields(reader.frame()));
      uint8_t out[160];
      const auto written = encode_message(reader.frame(), generation, out);
      TETHER_FUZZ_CHECK(written.ok());
      LinkCounters again_counters;
      Decoder<160> again(generation, again_counters);
      bool seen = false;
      for (size_t j = 0; j < written.value(); ++j) {
        const DecodeStatus e = again.feed(out[j]);
        TETHER_FUZZ_CHECK(e != DecodeStatus::error);
        if (e != DecodeStatus::frame) continue;
        uint8_t second[160];
        const auto rewritten = encode_message(again.frame(), generation, second);
        TETHER_FUZZ_CHECK(rewritten.ok() && rewritten.value() == written.value());
        for (size_t k = 0; k < written.value(); ++k) TETHER_FUZZ_CHECK(second[k] == out[k]);
        seen = true;
      }
      TETHER_FUZZ_CHECK(seen);
    }
  }
  return 0;
}
