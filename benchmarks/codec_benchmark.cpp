// Host cost of each codec per message: encode a frame and decode it with the incremental decoder, for
// messages of comparable content (a command with two small integers, and a 32-character string); the
// Elcano ring node's per-message work (forward, capture); and the wire bytes of one job, "drive both
// servos", in each protocol (BM_DriveJob_*: counters computed from the encoders).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/elcano/encoder.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether_proxy.pb.h"
#include "tether/romi/encoder.hpp"
#include "tether/romi/decoder.hpp"
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
  // The frame's size, for the tables (outside the timed loop).
  romi::RequestBuilder builder('s');
  builder.add_int(1234).add_int(-567);
  const Result<size_t> size = romi::encode_request(builder.payload(), id, frame);
  state.counters["wire_bytes"] = static_cast<double>(size.ok() ? size.value() : 0);
}
BENCHMARK(BM_RomiEncodeRequest);

void BM_RomiDecodeAndParseRequest(benchmark::State& state) {
  uint8_t frame[64];
  romi::RequestBuilder builder('s');
  builder.add_int(1234).add_int(-567);
  const size_t size = romi::encode_request(builder.payload(), 7, frame).value();
  LinkCounters counters;
  romi::Decoder<romi::kDeviceDecoderCapacity> decoder(counters);
  romi::Request request;
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) {
      if (decoder.feed(frame[i]) == DecodeStatus::frame) {
        benchmark::DoNotOptimize(romi::parse_request(decoder.frame().payload, request));
      }
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
  const Result<size_t> size =
      proxy::encode_frame(ByteView(payload.data(), payload.size()), proxy::Integrity::crc16, true, frame);
  state.counters["wire_bytes"] = static_cast<double>(size.ok() ? size.value() : 0);
}
BENCHMARK(BM_ProxyEncodeFrame);

void BM_ProxyDecodeFrame(benchmark::State& state) {
  const auto payload = servo_control_payload();
  uint8_t frame[64];
  const size_t size =
      proxy::encode_frame(ByteView(payload.data(), payload.size()), proxy::Integrity::crc16, true, frame).value();
  LinkCounters counters;
  proxy::Decoder<64> decoder(proxy::Integrity::crc16, counters);
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) benchmark::DoNotOptimize(decoder.feed(frame[i]));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_ProxyDecodeFrame);

void BM_RomiDecodeLongResponse(benchmark::State& state) {
  // A 101-value response line as a host reads it (the reference host could not read past 57 chars).
  std::string body = "[0";
  for (int i = 0; i < 100; ++i) body += ",1234";
  body += "]";
  uint8_t frame[1024];
  const size_t size = romi::encode_response('r', ByteView::from_chars(body.data(), body.size()), 3, frame).value();
  LinkCounters counters;
  romi::Decoder<romi::kHostDecoderCapacity> decoder(counters);
  for (auto _ : state) {
    for (size_t i = 0; i < size; ++i) benchmark::DoNotOptimize(decoder.feed(frame[i]));
  }
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(size));
  state.counters["wire_bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_RomiDecodeLongResponse);

// --- Elcano ----------------------------------------------------------------------------------------------
// A drive message D{s 50}{a 25} and a segment X{n 4}{s 160}{b 80}{p 3200,-64000} (docs/elcano.md), in
// generation B (spaces, no check) and D (no spaces, CRC-8 trailer).

elcano::Message elcano_drive() { return elcano::Message::drive(50, 25); }

elcano::Message elcano_segment() { return elcano::Message::segment(4, 160, 80, 3200, -64000); }

std::vector<uint8_t> elcano_bytes(const elcano::Message& message, elcano::Generation generation) {
  uint8_t out[96];
  const Result<size_t> size = elcano::encode_message(message, generation, out);
  return std::vector<uint8_t>(out, out + (size.ok() ? size.value() : 0));
}

void BM_ElcanoWrite(benchmark::State& state, elcano::Message message, elcano::Generation generation) {
  uint8_t out[96];
  for (auto _ : state) benchmark::DoNotOptimize(elcano::encode_message(message, generation, out));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(elcano_bytes(message, generation).size());
}
BENCHMARK_CAPTURE(BM_ElcanoWrite, drive_gen_b, elcano_drive(), elcano::Generation::b);
BENCHMARK_CAPTURE(BM_ElcanoWrite, drive_gen_d, elcano_drive(), elcano::Generation::d);
BENCHMARK_CAPTURE(BM_ElcanoWrite, segment_gen_b, elcano_segment(), elcano::Generation::b);
BENCHMARK_CAPTURE(BM_ElcanoWrite, segment_gen_d, elcano_segment(), elcano::Generation::d);

// Byte by byte through the boards' reader (Decoder<96>), one message per iteration.
void BM_ElcanoRead(benchmark::State& state, elcano::Message message, elcano::Generation generation) {
  const std::vector<uint8_t> bytes = elcano_bytes(message, generation);
  LinkCounters counters;
  elcano::Decoder<96> reader(generation, counters);
  for (auto _ : state) {
    for (uint8_t byte : bytes) benchmark::DoNotOptimize(reader.feed(byte));
  }
  if (counters.frames_ok != static_cast<uint64_t>(state.iterations())) state.SkipWithError("a message was not read");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(bytes.size()));
  state.counters["wire_bytes"] = static_cast<double>(bytes.size());
}
BENCHMARK_CAPTURE(BM_ElcanoRead, drive_gen_b, elcano_drive(), elcano::Generation::b);
BENCHMARK_CAPTURE(BM_ElcanoRead, drive_gen_d, elcano_drive(), elcano::Generation::d);
BENCHMARK_CAPTURE(BM_ElcanoRead, segment_gen_b, elcano_segment(), elcano::Generation::b);
BENCHMARK_CAPTURE(BM_ElcanoRead, segment_gen_d, elcano_segment(), elcano::Generation::d);

// One message through a ring node (the host's and the boards' RingNode<96, 256, 4>): feed its bytes, then
// take_output. A node that does not capture the type forwards it; one that does captures it (no output).
// The clock advances 10 ms per message, so the pacer (115200 baud, 64-byte receiver) never holds bytes back.
void BM_ElcanoRingNode(benchmark::State& state, elcano::Message message, elcano::Generation generation,
                       bool capture) {
  const std::vector<uint8_t> bytes = elcano_bytes(message, generation);
  elcano::RingNodeConfig config;
  config.generation = generation;
  if (capture) config.capture = elcano::TypeSet::of(message.type);
  LinkCounters link;
  elcano::RingCounters ring;
  Millis now = 0;
  elcano::RingNode<96, 256, 4> node(config, now, link, ring);
  uint8_t out[256];
  size_t output_bytes = 0;
  for (auto _ : state) {
    for (uint8_t byte : bytes) benchmark::DoNotOptimize(node.feed(byte, now));
    output_bytes += node.take_output(out, now);
    benchmark::DoNotOptimize(out);
    now += 10;
  }
  // A forwarded message leaves whitespace-stripped (generation B) or byte-identical (generation D).
  const auto stripped =
      static_cast<uint64_t>(std::count_if(bytes.begin(), bytes.end(), [](uint8_t b) { return b != ' '; }));
  const auto messages = static_cast<uint64_t>(state.iterations());
  const bool whole = capture ? ring.captured == messages && output_bytes == 0
                             : ring.forwarded == messages && output_bytes == messages * stripped;
  if (!whole) state.SkipWithError("a message was not forwarded or captured whole");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(bytes.size());
  state.counters["out_bytes"] = static_cast<double>(output_bytes) / static_cast<double>(messages);
}
BENCHMARK_CAPTURE(BM_ElcanoRingNode, forward_drive_gen_b, elcano_drive(), elcano::Generation::b, false);
BENCHMARK_CAPTURE(BM_ElcanoRingNode, forward_drive_gen_d, elcano_drive(), elcano::Generation::d, false);
BENCHMARK_CAPTURE(BM_ElcanoRingNode, capture_drive_gen_b, elcano_drive(), elcano::Generation::b, true);

// --- A ~32-byte frame per codec: encode, then decode as the host client does ---------------------------
// The per-frame cost a host pays in the portable codecs (the clients add their own bookkeeping on top).
// Each is decoded a received run at a time (`feed(ByteView)`), as its host client feeds it. Romi: the
// request `#s[1234,-567,890,-12,345]:<id><crc>\r\n` (32 bytes). Proxy: a 28-byte payload, CRC-16 and COBS
// (32 bytes with the delimiter). Elcano: the segment `X{n 4}{s 160}{b 80}{p 3200,-64000}\n` (generation B,
// 35 bytes).

// Romi: the RomiClient hands each received run to its decoder (`Decoder::feed(ByteView)`); the
// byte-by-byte row is `feed(byte)`, the device's way.
template <typename Read>
void frame32_romi(benchmark::State& state, const LinkCounters& counters, Read read) {
  uint8_t frame[64];
  uint8_t id = 0;
  size_t size = 0;
  for (auto _ : state) {
    romi::RequestBuilder builder('s');
    builder.add_int(1234).add_int(-567).add_int(890).add_int(-12).add_int(345);
    const Result<size_t> encoded = romi::encode_request(builder.payload(), id++, frame);
    size = encoded.ok() ? encoded.value() : 0;
    read(ByteView(frame, size));
  }
  if (counters.frames_ok != static_cast<uint64_t>(state.iterations())) state.SkipWithError("a frame was not read");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}

void BM_Frame32_Romi(benchmark::State& state) {
  LinkCounters counters;
  romi::Decoder<romi::kHostDecoderCapacity> decoder(counters);
  frame32_romi(state, counters, [&](ByteView bytes) { benchmark::DoNotOptimize(decoder.feed(bytes)); });
}
BENCHMARK(BM_Frame32_Romi);

void BM_Frame32_RomiByteByByte(benchmark::State& state) {
  LinkCounters counters;
  romi::Decoder<romi::kHostDecoderCapacity> decoder(counters);
  frame32_romi(state, counters, [&](ByteView bytes) {
    for (const uint8_t byte : bytes) benchmark::DoNotOptimize(decoder.feed(byte));
  });
}
BENCHMARK(BM_Frame32_RomiByteByByte);

void BM_Frame32_Proxy(benchmark::State& state) {
  std::vector<uint8_t> payload(28);
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<uint8_t>(i * 37 + 1);
  payload[9] = 0;  // a zero in the payload, as protobuf varints carry them
  uint8_t frame[64];
  LinkCounters counters;
  proxy::Decoder<64> decoder(proxy::Integrity::crc16, counters);
  size_t size = 0;
  for (auto _ : state) {
    const Result<size_t> encoded =
        proxy::encode_frame(ByteView(payload.data(), payload.size()), proxy::Integrity::crc16, false, frame);
    size = encoded.ok() ? encoded.value() : 0;
    benchmark::DoNotOptimize(decoder.feed(ByteView(frame, size)));
  }
  if (counters.frames_ok != static_cast<uint64_t>(state.iterations())) state.SkipWithError("a frame was not read");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}
BENCHMARK(BM_Frame32_Proxy);

// Elcano: the RingClient hands each received run to its node (`RingNode::consume(bytes)`, the reader's
// `feed(bytes)`); the byte-by-byte row is the reader as `feed(byte)` takes it, and the node row what the
// client's node adds (the partial-message deadline, the loop check, the capture set).
template <typename Read>
void frame32_elcano(benchmark::State& state, const LinkCounters& counters, Read read) {
  const elcano::Message message = elcano_segment();
  uint8_t out[96];
  size_t size = 0;
  for (auto _ : state) {
    const Result<size_t> encoded = elcano::encode_message(message, elcano::Generation::b, out);
    size = encoded.ok() ? encoded.value() : 0;
    read(ByteView(out, size));
  }
  if (counters.frames_ok != static_cast<uint64_t>(state.iterations())) state.SkipWithError("a frame was not read");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["wire_bytes"] = static_cast<double>(size);
}

void BM_Frame32_Elcano(benchmark::State& state) {
  LinkCounters counters;
  elcano::Decoder<96> decoder(elcano::Generation::b, counters);
  frame32_elcano(state, counters, [&](ByteView bytes) { benchmark::DoNotOptimize(decoder.feed(bytes)); });
}
BENCHMARK(BM_Frame32_Elcano);

void BM_Frame32_ElcanoByteByByte(benchmark::State& state) {
  LinkCounters counters;
  elcano::Decoder<96> decoder(elcano::Generation::b, counters);
  frame32_elcano(state, counters, [&](ByteView bytes) {
    for (const uint8_t byte : bytes) benchmark::DoNotOptimize(decoder.feed(byte));
  });
}
BENCHMARK(BM_Frame32_ElcanoByteByByte);

void BM_Frame32_ElcanoRingNode(benchmark::State& state) {
  elcano::RingNodeConfig config;
  config.capture = elcano::TypeSet::of(elcano::Type::segment);
  LinkCounters counters;
  elcano::RingCounters ring;
  elcano::RingNode<96, 256, 4> node(config, 0, counters, ring);
  frame32_elcano(state, counters, [&](ByteView bytes) {
    size_t consumed = 0;
    benchmark::DoNotOptimize(node.consume(bytes, 0, consumed));
  });
}
BENCHMARK(BM_Frame32_ElcanoRingNode);

// --- One job in each protocol: drive both servos (throttle D9, steering D10) ---------------------------
// Host cost of encoding the job and its bytes on the wire, computed from the encoders:
//   to_device: what the host sends; to_host: what the device answers (romi: the response line; proxy: a
//   PinState report and an Ack per ServoControl, as firmware/proxy sends them; elcano: nothing, the ring has
//   no acknowledgement); frames: messages the host sends.
// Romi: `S[1500,1500]` (romi-rover: pulses in us). Proxy: ServoControl{pin 9, 90} and {pin 10, 90} (degrees),
// messageId 0x12345678 (the client's ids start at a random 32-bit value: a 5-byte varint is typical).
// Elcano: D{s 50}{a 25}.

void BM_DriveJob_Romi(benchmark::State& state) {
  uint8_t frame[64];
  size_t to_device = 0;
  uint8_t id = 0x21;
  for (auto _ : state) {
    romi::RequestBuilder builder('S');
    builder.add_int(1500).add_int(1500);
    const Result<size_t> size = romi::encode_request(builder.payload(), id, frame);
    to_device = size.ok() ? size.value() : 0;
    benchmark::DoNotOptimize(frame);
  }
  const Result<size_t> response = romi::encode_response('S', ByteView::from_literal("[0]"), id, frame);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["to_device"] = static_cast<double>(to_device);
  state.counters["to_host"] = static_cast<double>(response.ok() ? response.value() : 0);
  state.counters["frames"] = 1;
}
BENCHMARK(BM_DriveJob_Romi);

size_t proxy_frame_size(const google::protobuf::MessageLite& message, bool leading_delimiter) {
  const std::string payload = message.SerializeAsString();
  uint8_t frame[128];
  const Result<size_t> size = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                  proxy::Integrity::crc16, leading_delimiter, frame);
  return size.ok() ? size.value() : 0;
}

void BM_DriveJob_Proxy(benchmark::State& state) {
  constexpr uint32_t kPins[2] = {9, 10};
  constexpr int32_t kPosition = 90;
  constexpr uint32_t kFirstId = 0x12345678;
  proxy::ArduinoIn message;
  std::string payload;
  uint8_t frame[128];
  size_t to_device = 0;
  for (auto _ : state) {
    to_device = 0;
    for (uint32_t k = 0; k < 2; ++k) {
      message.set_messageid(kFirstId + k);
      message.mutable_servocontrol()->set_pin(kPins[k]);
      message.mutable_servocontrol()->set_position(kPosition);
      message.SerializeToString(&payload);
      const Result<size_t> size = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                      proxy::Integrity::crc16, true, frame);
      to_device += size.ok() ? size.value() : 0;
      benchmark::DoNotOptimize(frame);
    }
  }
  size_t to_host = 0;
  for (uint32_t k = 0; k < 2; ++k) {
    proxy::ArduinoOut pin_state;
    pin_state.mutable_pinstate()->set_pin(kPins[k]);
    pin_state.mutable_pinstate()->set_value(kPosition);
    proxy::ArduinoOut ack;
    ack.mutable_ack()->set_messageid(kFirstId + k);
    to_host += proxy_frame_size(pin_state, false) + proxy_frame_size(ack, false);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["to_device"] = static_cast<double>(to_device);
  state.counters["to_host"] = static_cast<double>(to_host);
  state.counters["frames"] = 2;
}
BENCHMARK(BM_DriveJob_Proxy);

void BM_DriveJob_Elcano(benchmark::State& state, elcano::Generation generation) {
  const elcano::Message drive = elcano_drive();
  uint8_t out[96];
  size_t to_device = 0;
  for (auto _ : state) {
    const Result<size_t> size = elcano::encode_message(drive, generation, out);
    to_device = size.ok() ? size.value() : 0;
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["to_device"] = static_cast<double>(to_device);
  state.counters["to_host"] = 0;
  state.counters["frames"] = 1;
}
BENCHMARK_CAPTURE(BM_DriveJob_Elcano, gen_b, elcano::Generation::b);
BENCHMARK_CAPTURE(BM_DriveJob_Elcano, gen_d, elcano::Generation::d);

}  // namespace
