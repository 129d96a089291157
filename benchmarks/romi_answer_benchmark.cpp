// Host cost of reading one Romi answer, JSON values included: the frame's bytes through the host decoder
// (a received run at a time, as the client feeds it), then its payload into a `RomiResponse`
// (`romi::parse_answer`: typed values, nlohmann SAX). Compared with the same decoder followed by a nlohmann
// DOM (`json::parse`), the shape of the reference host client (its own figures, measured outside the
// project: ~310 ns for `#e[0,1,2]`, ~710 ns for 8 values) and of Tether before typed values; and with the
// cost of converting typed values to a DOM on request.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "tether/romi/decoder.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/response.hpp"

namespace {

using namespace tether;

// The answer frame `#e<body>:<id><crc>\r\n` as the device sends it.
std::string answer_frame(const std::string& body) {
  uint8_t frame[256];
  const Result<size_t> size = romi::encode_response('e', ByteView::from_chars(body.data(), body.size()), 0, frame);
  return std::string(reinterpret_cast<const char*>(frame), size.ok() ? size.value() : 0);
}

const char* const kThreeValues = "[0,1,2]";                            // the spec's `#e` answer
const char* const kEightValues = "[0,512,-3,1023,77,-32768,32767,4]";  // eight values, code included

enum class Reading { typed, dom, typed_then_json };

void BM_RomiAnswer(benchmark::State& state, const char* body, Reading reading) {
  const std::string frame = answer_frame(body);
  LinkCounters counters;
  romi::Decoder<romi::kHostDecoderCapacity> decoder(counters);
  std::int64_t checksum = 0;
  for (auto _ : state) {
    // A received run at a time, as the RomiClient feeds its decoder.
    for (ByteView rest = ByteView::from_chars(frame.data(), frame.size()); !rest.empty();) {
      const FeedResult fed = decoder.feed(rest);
      rest = rest.subview(fed.consumed);
      if (fed.status != DecodeStatus::frame) continue;
      const ByteView payload = decoder.frame().payload;
      switch (reading) {
        case Reading::typed: {
          const romi::RomiResponse response = romi::parse_answer(payload, decoder.frame().opcode);
          checksum += response.values[response.values.size() - 1].integer();
          break;
        }
        case Reading::dom: {
          const auto* text = reinterpret_cast<const char*>(payload.data());
          const nlohmann::json values = nlohmann::json::parse(text + 1, text + payload.size(), nullptr, false);
          checksum += values.back().get<std::int64_t>();
          break;
        }
        case Reading::typed_then_json: {
          const romi::RomiResponse response = romi::parse_answer(payload, decoder.frame().opcode);
          const nlohmann::json values = response.values;
          checksum += values.back().get<std::int64_t>();
          break;
        }
      }
    }
  }
  benchmark::DoNotOptimize(checksum);
  if (counters.frames_ok != static_cast<uint64_t>(state.iterations())) state.SkipWithError("an answer was not read");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(frame.size());
}
BENCHMARK_CAPTURE(BM_RomiAnswer, typed_3_values, kThreeValues, Reading::typed);
BENCHMARK_CAPTURE(BM_RomiAnswer, dom_3_values, kThreeValues, Reading::dom);
BENCHMARK_CAPTURE(BM_RomiAnswer, typed_then_json_3_values, kThreeValues, Reading::typed_then_json);
BENCHMARK_CAPTURE(BM_RomiAnswer, typed_8_values, kEightValues, Reading::typed);
BENCHMARK_CAPTURE(BM_RomiAnswer, dom_8_values, kEightValues, Reading::dom);
BENCHMARK_CAPTURE(BM_RomiAnswer, typed_then_json_8_values, kEightValues, Reading::typed_then_json);

}  // namespace
