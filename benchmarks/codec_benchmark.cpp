// Host cost of each codec per message: encode a frame and decode it with the incremental decoder, for
// messages of comparable content (a command with two small integers, and a 32-character string).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <string>
#include <vector>

#include "tether/proxy/frame.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/envelope_decoder.hpp"
#include "tether/romi/request_parser.hpp"

namespace {

using namespace tether;

void BM_RomiEncodeRequest(benchmark::State& state) {
  uint8_t frame[64];
  uint8_t id = 0;
  for (auto _ : state) {
    romi::RequestBuilder builder('s');
    builder.add_int(1234).add_int(-567);
    benchmark::DoNotOptimize(romi::encode_request(builder.payload(), id++, frame));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_RomiEncodeRequest);

void BM_RomiDecodeAndParseRequest(benchmark::State& state) {
  uint8_t frame[64];
  romi::RequestBuilder builder('s');
  builder.add_int(1234).add_int(-567);
  const size_t size = romi::encode_request(builder.payload(), 7, frame).value();
  LinkCounters counters;
  romi::EnvelopeDecoder<romi::kDeviceDecoderCapacity> decoder(counters);
  romi::Request request;
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) {
      const romi::EnvelopeEvent event = decoder.feed(frame[i]);
      if (event.kind == romi::EnvelopeEvent::Kind::frame) benchmark::DoNotOptimize(romi::parse_request(event.payload, request));
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_RomiDecodeAndParseRequest);

// The proxy frame of a ServoControl{pin 9, position 123} with messageId 0x12345678, as protobuf bytes.
std::vector<uint8_t> servo_control_payload() {
  return {0x08, 0xf8, 0xac, 0xd1, 0x91, 0x01, 0x22, 0x04, 0x08, 0x09, 0x10, 0x7b};
}

void BM_ProxyEncodeFrame(benchmark::State& state) {
  const auto payload = servo_control_payload();
  uint8_t frame[64];
  for (auto _ : state) {
    benchmark::DoNotOptimize(proxy::encode_frame(ByteView(payload.data(), payload.size()), proxy::Integrity::crc16,
                                                 true, frame));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_ProxyEncodeFrame);

void BM_ProxyDecodeFrame(benchmark::State& state) {
  const auto payload = servo_control_payload();
  uint8_t frame[64];
  const size_t size =
      proxy::encode_frame(ByteView(payload.data(), payload.size()), proxy::Integrity::crc16, true, frame).value();
  LinkCounters counters;
  proxy::FrameDecoder<64> decoder(proxy::Integrity::crc16, counters);
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) benchmark::DoNotOptimize(decoder.feed(frame[i]));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_ProxyDecodeFrame);

void BM_RomiDecodeLongResponse(benchmark::State& state) {
  // A 200-value response line as a host reads it (the reference host could not read past 57 chars).
  std::string body = "[0";
  for (int i = 0; i < 100; ++i) body += ",1234";
  body += "]";
  uint8_t frame[1024];
  const size_t size = romi::encode_response('r', ByteView::from_chars(body.data(), body.size()), 3, frame).value();
  LinkCounters counters;
  romi::EnvelopeDecoder<romi::kHostDecoderCapacity> decoder(counters);
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) benchmark::DoNotOptimize(decoder.feed(frame[i]));
  }
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(size));
}
BENCHMARK(BM_RomiDecodeLongResponse);

}  // namespace
