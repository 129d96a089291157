// COBS and the proxy frame: the spec's vectors, COBS edge cases, resynchronisation, bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "tether/core/crc.hpp"
#include "tether/proxy/boot_frame.hpp"
#include "tether/proxy/cobs.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether::proxy {
namespace {

using Bytes = std::vector<uint8_t>;

Bytes encode(const Bytes& input) {
  Bytes out(cobs_max_encoded_size(input.size()));
  const auto size = cobs_encode(ByteView(input.data(), input.size()), MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  out.resize(size.value());
  return out;
}

Bytes decode(const Bytes& encoded) {
  Bytes out(encoded.size() + 1);
  const auto size = cobs_decode(ByteView(encoded.data(), encoded.size()), MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  out.resize(size.ok() ? size.value() : 0);
  return out;
}

Bytes frame(const Bytes& payload, Integrity integrity, bool lead) {
  Bytes out(max_frame_size(payload.size()));
  const auto size =
      encode_frame(ByteView(payload.data(), payload.size()), integrity, lead, MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  out.resize(size.value());
  return out;
}

// Feeds a byte stream to a frame decoder; returns the payloads and the error statuses, in order.
template <size_t Max = 256>
std::pair<std::vector<Bytes>, std::vector<FrameError>> receive(const Bytes& wire, Integrity integrity,
                                                           LinkCounters* counters_out = nullptr) {
  LinkCounters counters;
  Decoder<Max> decoder(integrity, counters);
  std::vector<Bytes> payloads;
  std::vector<FrameError> errors;
  for (uint8_t byte : wire) {
    const DecodeStatus status = decoder.feed(byte);
    if (status == DecodeStatus::frame) payloads.emplace_back(decoder.frame().begin(), decoder.frame().end());
    if (status == DecodeStatus::error) errors.push_back(decoder.error());
  }
  if (counters_out) *counters_out = counters;
  return {payloads, errors};
}

TEST(Cobs, EdgeCases) {
  EXPECT_EQ(encode({}), (Bytes{0x01}));
  EXPECT_EQ(encode({0x00}), (Bytes{0x01, 0x01}));
  EXPECT_EQ(encode({0x00, 0x00}), (Bytes{0x01, 0x01, 0x01}));
  EXPECT_EQ(encode({0x11, 0x00, 0x22}), (Bytes{0x02, 0x11, 0x02, 0x22}));
  EXPECT_EQ(encode({0x11, 0x22, 0x00}), (Bytes{0x03, 0x11, 0x22, 0x01}));
  for (const size_t run : {size_t{253}, size_t{254}, size_t{255}, size_t{508}}) {
    Bytes data(run);
    for (size_t i = 0; i < run; ++i) data[i] = static_cast<uint8_t>(1 + i % 255);
    const Bytes encoded = encode(data);
    // One code byte per started block of 254, plus the final code byte after a full last block.
    EXPECT_EQ(encoded.size(), run + 1 + run / 254) << run;
    EXPECT_EQ(encoded[0], run >= 254 ? 0xFF : run + 1) << run;
    for (uint8_t byte : encoded) EXPECT_NE(byte, 0x00);
    EXPECT_EQ(decode(encoded), data) << run;
  }
  // A zero right at a block end: 254 non-zero bytes, then 0x00.
  Bytes block_end(254, 0x42);
  block_end.push_back(0x00);
  EXPECT_EQ(decode(encode(block_end)), block_end);
}

TEST(Cobs, AllZerosAndRandomBuffersRoundTrip) {
  Bytes zeros(600, 0x00);
  EXPECT_EQ(decode(encode(zeros)), zeros);
  auto random = tether::testing::seeded_generator(3);
  for (int round = 0; round < 2000; ++round) {
    Bytes data(random() % 700);
    const int zero_bias = static_cast<int>(random() % 4);
    for (auto& b : data) b = (random() % 4 < static_cast<unsigned>(zero_bias)) ? 0 : static_cast<uint8_t>(random());
    const Bytes encoded = encode(data);
    ASSERT_LE(encoded.size(), cobs_max_encoded_size(data.size()));
    for (uint8_t byte : encoded) ASSERT_NE(byte, 0x00);
    ASSERT_EQ(decode(encoded), data) << "round " << round;
  }
}

TEST(Cobs, InvalidEncodingsAreRejected) {
  Bytes out(16);
  EXPECT_EQ(cobs_decode(ByteView(Bytes{0x03, 0x11}.data(), 2), MutableByteView(out.data(), out.size())).status(),
            Status::framing_error);  // the code promises two data bytes, one follows
  const Bytes with_zero = {0x02, 0x00};
  EXPECT_EQ(cobs_decode(ByteView(with_zero.data(), 2), MutableByteView(out.data(), out.size())).status(),
            Status::framing_error);
}

TEST(ProxyFrame, PrimaryWorkedExample) {
  const Bytes payload = {0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09};
  const Bytes wire = {0x0b, 0x57, 0x88, 0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09, 0x00};
  EXPECT_EQ(frame(payload, Integrity::crc16, false), wire);
  const auto [payloads, errors] = receive(wire, Integrity::crc16);
  ASSERT_EQ(payloads.size(), 1u);
  EXPECT_EQ(payloads[0], payload);
  EXPECT_TRUE(errors.empty());
}

TEST(ProxyFrame, CompatibilityVectors) {
  // Host to device: 0x00 ‖ COBS(pb) ‖ 0x00, no CRC.
  EXPECT_EQ(frame({0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09}, Integrity::none, true),
            (Bytes{0x00, 0x09, 0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09, 0x00}));  // ServoInit{1823, 1231}
  EXPECT_EQ(frame({0x12, 0x05, 0x08, 0x05, 0x10, 0xb4, 0x01}, Integrity::none, true),
            (Bytes{0x00, 0x08, 0x12, 0x05, 0x08, 0x05, 0x10, 0xb4, 0x01, 0x00}));  // ServoControl{5, 180}
  EXPECT_EQ(frame({0x22, 0x04, 0x08, 0x0d, 0x10, 0x01}, Integrity::none, true),
            (Bytes{0x00, 0x07, 0x22, 0x04, 0x08, 0x0d, 0x10, 0x01, 0x00}));  // DigitalControl{13, true}
  EXPECT_EQ(frame({0x2a, 0x00}, Integrity::none, true), (Bytes{0x00, 0x02, 0x2a, 0x01, 0x00}));  // Reset{}
  // Device to host: COBS(pb) ‖ 0x00.
  const auto [payloads, errors] = receive({0x02, 0x0a, 0x01, 0x00,                                // EventMessage{RESET}
                                           0x07, 0x12, 0x04, 0x08, 0x02, 0x10, 0x0d, 0x00,        // ErrorMessage{PIN_NOT_INITIALIZED, 13}
                                           0x05, 0x22, 0x02, 0x08, 0x08, 0x00},                    // DigitalState{8, false}
                                          Integrity::none);
  ASSERT_EQ(payloads.size(), 3u);
  EXPECT_EQ(payloads[0], (Bytes{0x0a, 0x00}));
  EXPECT_EQ(payloads[1], (Bytes{0x12, 0x04, 0x08, 0x02, 0x10, 0x0d}));
  EXPECT_EQ(payloads[2], (Bytes{0x22, 0x02, 0x08, 0x08}));
}

TEST(ProxyFrame, EmptyFramesAndLeadingDelimitersAreIgnored) {
  Bytes wire = {0x00, 0x00, 0x00};
  const Bytes one = frame({0x01, 0x02}, Integrity::crc16, true);
  wire.insert(wire.end(), one.begin(), one.end());
  const auto [payloads, errors] = receive(wire, Integrity::crc16);
  EXPECT_EQ(payloads.size(), 1u);
  EXPECT_TRUE(errors.empty());
}

TEST(ProxyFrame, CorruptedFramesAreDroppedByCauseAndTheNextFrameArrives) {
  const Bytes good = frame({0x08, 0x01, 0x10, 0x02}, Integrity::crc16, false);
  Bytes crc_damaged = good;
  crc_damaged[3] ^= 0x10;  // a payload bit: the CRC no longer matches
  Bytes wire = crc_damaged;
  wire.insert(wire.end(), {0x05, 0x11, 0x00});  // COBS says 4 data bytes, the frame ends after 1: bad COBS
  wire.insert(wire.end(), {0x02, 0x33, 0x00});  // one byte: too short for a CRC
  wire.insert(wire.end(), good.begin(), good.end());
  LinkCounters counters;
  const auto [payloads, errors] = receive(wire, Integrity::crc16, &counters);
  ASSERT_EQ(payloads.size(), 1u);
  EXPECT_EQ(errors, (std::vector<FrameError>{FrameError::crc_mismatch, FrameError::framing_error, FrameError::framing_error}));
  EXPECT_EQ(counters.crc_errors, 1u);
  EXPECT_EQ(counters.framing_errors, 2u);
  EXPECT_EQ(counters.frames_ok, 1u);
}

TEST(ProxyFrame, OversizeFrameIsDroppedOnceAndTheDecoderResynchronises) {
  Bytes big(100, 0x55);
  Bytes wire = frame(big, Integrity::crc16, false);
  const Bytes good = frame({0x01}, Integrity::crc16, false);
  wire.insert(wire.end(), good.begin(), good.end());
  LinkCounters counters;
  const auto [payloads, errors] = receive<32>(wire, Integrity::crc16, &counters);
  EXPECT_EQ(errors, (std::vector<FrameError>{FrameError::frame_too_long}));
  ASSERT_EQ(payloads.size(), 1u);
  EXPECT_EQ(payloads[0], (Bytes{0x01}));
  EXPECT_EQ(counters.oversize_frames, 1u);
  // Exactly the maximum fits.
  const auto [fits, no_errors] = receive<32>(frame(Bytes(32, 0x07), Integrity::crc16, false), Integrity::crc16);
  EXPECT_EQ(fits.size(), 1u);
  EXPECT_TRUE(no_errors.empty());
}

TEST(ProxyFrame, CompatModeBoundsThePayloadToo) {
  // Regression (found by the fuzz target): without a CRC, payloads up to two bytes over the bound passed.
  for (const size_t size : {size_t{33}, size_t{34}}) {
    LinkCounters counters;
    const auto [payloads, errors] = receive<32>(frame(Bytes(size, 0x07), Integrity::none, true), Integrity::none, &counters);
    EXPECT_TRUE(payloads.empty()) << size;
    EXPECT_EQ(errors, (std::vector<FrameError>{FrameError::frame_too_long})) << size;
    EXPECT_EQ(counters.oversize_frames, 1u);
  }
  EXPECT_EQ(receive<32>(frame(Bytes(32, 0x07), Integrity::none, true), Integrity::none).first.size(), 1u);
}

TEST(ProxyFrame, ResynchronisesAfterRandomGarbage) {
  auto random = tether::testing::seeded_generator(17);
  std::vector<Bytes> sent;
  Bytes wire;
  for (int i = 0; i < 300; ++i) {
    Bytes garbage(random() % 40);
    for (auto& b : garbage) b = static_cast<uint8_t>(random());
    wire.insert(wire.end(), garbage.begin(), garbage.end());
    Bytes payload(1 + random() % 60);
    for (auto& b : payload) b = static_cast<uint8_t>(random());
    sent.push_back(payload);
    const Bytes f = frame(payload, Integrity::crc16, true);  // the leading 0x00 ends the garbage
    wire.insert(wire.end(), f.begin(), f.end());
  }
  const auto [payloads, errors] = receive(wire, Integrity::crc16);
  EXPECT_EQ(payloads, sent);  // every frame after garbage arrives; garbage never passes as a frame
}

TEST(ProxyFrame, RandomPayloadsRoundTripThroughTheFrameLayerInPlace) {
  // encode_frame folds the CRC into its COBS pass and patches the CRC bytes afterwards: check it against
  // the plain decoder for payloads with all zero densities and block-boundary sizes.
  auto random = tether::testing::seeded_generator(29);
  for (int round = 0; round < 3000; ++round) {
    Bytes payload(random() % 600);
    const unsigned zeros = static_cast<unsigned>(random() % 3);
    for (auto& b : payload) b = random() % 3 < zeros ? 0 : static_cast<uint8_t>(random());
    const Bytes wire = frame(payload, round % 2 ? Integrity::crc16 : Integrity::none, round % 3 == 0);
    const auto [payloads, errors] = receive<700>(wire, round % 2 ? Integrity::crc16 : Integrity::none);
    ASSERT_TRUE(errors.empty()) << "round " << round;
    ASSERT_EQ(payloads.size(), payload.empty() && round % 2 == 0 ? 0u : 1u) << "round " << round;
    if (!payloads.empty()) {
      ASSERT_EQ(payloads[0], payload) << "round " << round;
    }
  }
}

// The first payload found by counting through `varying` trailing bytes after `prefix` whose CRC-16 has
// a zero low byte, high byte, or both (`zero_low`, `zero_high`).
Bytes payload_with_crc(const Bytes& prefix, bool zero_low, bool zero_high) {
  Bytes payload = prefix;
  payload.resize(prefix.size() + 3);
  for (uint32_t n = 0; n < (1u << 24); ++n) {
    payload[prefix.size()] = static_cast<uint8_t>(n);
    payload[prefix.size() + 1] = static_cast<uint8_t>(n >> 8);
    payload[prefix.size() + 2] = static_cast<uint8_t>(n >> 16);
    const uint16_t crc = Crc16Mcrf4xx::compute(ByteView(payload.data(), payload.size()));
    if (((crc & 0xFF) == 0) == zero_low && ((crc >> 8) == 0) == zero_high) return payload;
  }
  ADD_FAILURE() << "no payload found";
  return payload;
}

TEST(ProxyFrame, ZeroCrcBytesGiveTheCanonicalCobsEncoding) {
  // encode_frame reserves the CRC's two bytes and patches them after the payload: a zero among them
  // splits the first block, and a full first block (254 bytes, no zero after it) is encoded again.
  // Every case must give exactly COBS(crc ‖ payload), and decode back.
  const Bytes short_prefix = {0x0a, 0x06, 0x08};
  const Bytes full_block_prefix(252, 0x5a);  // with the CRC: a first block of 254 non-zero bytes
  for (const Bytes& prefix : {short_prefix, full_block_prefix}) {
    for (const auto& [zero_low, zero_high] : {std::pair{true, false}, {false, true}, {true, true}, {false, false}}) {
      const Bytes payload = payload_with_crc(prefix, zero_low, zero_high);
      const uint16_t crc = Crc16Mcrf4xx::compute(ByteView(payload.data(), payload.size()));
      Bytes raw = {static_cast<uint8_t>(crc & 0xFF), static_cast<uint8_t>(crc >> 8)};
      raw.insert(raw.end(), payload.begin(), payload.end());
      Bytes expected = encode(raw);
      expected.push_back(0x00);
      const std::string which = "prefix " + std::to_string(prefix.size()) + ", crc " + std::to_string(crc);
      EXPECT_EQ(frame(payload, Integrity::crc16, false), expected) << which;
      const auto [payloads, errors] = receive<300>(frame(payload, Integrity::crc16, true), Integrity::crc16);
      EXPECT_TRUE(errors.empty()) << which;
      EXPECT_EQ(payloads, std::vector<Bytes>{payload}) << which;
    }
  }
}

// What a link may deliver: frames (payloads up to `max_payload`, zeros included, some past the decoder's
// bound), frames with a byte changed or cut short, garbage and lone delimiters.
Bytes random_wire(std::mt19937_64& random, Integrity integrity, size_t max_payload) {
  Bytes wire;
  for (int part = 0; part < 12; ++part) {
    const unsigned kind = static_cast<unsigned>(random() % 10);
    if (kind == 8) {  // garbage, zeros included
      for (size_t i = random() % 40; i != 0; --i) wire.push_back(static_cast<uint8_t>(random() % 3 == 0 ? 0 : random()));
      continue;
    }
    if (kind == 9) {  // delimiters between frames
      wire.insert(wire.end(), 1 + random() % 3, 0x00);
      continue;
    }
    Bytes payload(random() % (max_payload + 1));
    for (auto& b : payload) b = random() % 4 == 0 ? 0 : static_cast<uint8_t>(random());
    Bytes f = frame(payload, integrity, random() % 2 == 0);
    if (kind < 2 && f.size() > 2) f[random() % (f.size() - 1)] ^= static_cast<uint8_t>(1 + random() % 255);
    if (kind == 2) f.resize(random() % (f.size() + 1));  // cut short
    wire.insert(wire.end(), f.begin(), f.end());
  }
  return wire;
}

// Decoder::feed(ByteView) takes a block's data bytes in one run (on the host: a scan, a copy and the CRC of
// the whole block); it must stop at the same events, with the same frames, errors and counters, as
// byte-at-a-time feeding, whatever the chunking: the whole stream in one read, single bytes, or reads of
// 1..`max_chunk` bytes.
template <size_t Capacity>
void expect_spans_give_what_bytes_give(uint64_t seed, size_t max_payload, size_t max_chunk) {
  auto random = tether::testing::seeded_generator(seed);
  for (const Integrity integrity : {Integrity::crc16, Integrity::none}) {
    for (int round = 0; round < 300; ++round) {
      const Bytes wire = random_wire(random, integrity, max_payload);
      LinkCounters byte_counters;
      Decoder<Capacity> by_byte(integrity, byte_counters);
      std::vector<std::pair<DecodeStatus, Bytes>> expected;
      for (size_t i = 0; i < wire.size(); ++i) {
        const DecodeStatus status = by_byte.feed(wire[i]);
        if (status == DecodeStatus::frame) expected.emplace_back(status, Bytes(by_byte.frame().begin(), by_byte.frame().end()));
        if (status == DecodeStatus::error) {
          expected.emplace_back(status, Bytes{static_cast<uint8_t>(by_byte.error()), static_cast<uint8_t>(i), static_cast<uint8_t>(i >> 8)});
        }
      }
      LinkCounters span_counters;
      Decoder<Capacity> by_span(integrity, span_counters);
      std::vector<std::pair<DecodeStatus, Bytes>> got;
      const unsigned split = static_cast<unsigned>(round % 3);
      size_t at = 0;
      while (at < wire.size()) {
        const size_t chunk = split == 0 ? wire.size() : split == 1 ? 1 : 1 + random() % max_chunk;
        ByteView rest(wire.data() + at, std::min(chunk, wire.size() - at));
        while (!rest.empty()) {
          const FeedResult fed = by_span.feed(rest);
          ASSERT_GE(fed.consumed, 1u);
          const size_t last = at + fed.consumed - 1;
          if (fed.status == DecodeStatus::frame) got.emplace_back(fed.status, Bytes(by_span.frame().begin(), by_span.frame().end()));
          if (fed.status == DecodeStatus::error) {
            got.emplace_back(fed.status, Bytes{static_cast<uint8_t>(by_span.error()), static_cast<uint8_t>(last), static_cast<uint8_t>(last >> 8)});
          }
          at += fed.consumed;
          rest = rest.subview(fed.consumed);
        }
      }
      ASSERT_EQ(got, expected) << "round " << round << ", " << wire.size() << " bytes";
      EXPECT_EQ(span_counters.frames_ok, byte_counters.frames_ok);
      EXPECT_EQ(span_counters.crc_errors, byte_counters.crc_errors);
      EXPECT_EQ(span_counters.framing_errors, byte_counters.framing_errors);
      EXPECT_EQ(span_counters.oversize_frames, byte_counters.oversize_frames);
      EXPECT_EQ(span_counters.resyncs, byte_counters.resyncs);
      EXPECT_EQ(by_span.in_frame(), by_byte.in_frame());
    }
  }
}

TEST(ProxyFrame, FeedingSpansGivesTheSameEventsAsFeedingBytes) {
  expect_spans_give_what_bytes_give<48>(31, 80, 40);  // 8-bit counts (the AVR's decoders)
}

TEST(ProxyFrame, FeedingSpansGivesTheSameEventsAsFeedingBytesPastAByteOfCount) {
  expect_spans_give_what_bytes_give<300>(4, 400, 300);  // 16-bit counts, runs longer than 255 bytes
}

TEST(ProxyFrame, TooSmallBufferIsReported) {
  Bytes out(5);
  const Bytes payload(10, 1);
  EXPECT_EQ(encode_frame(ByteView(payload.data(), payload.size()), Integrity::crc16, false,
                         MutableByteView(out.data(), out.size()))
                .status(),
            Status::buffer_too_small);
}

// The boot announcement: a frame between two 0x00 after whatever came before it; shorter runs are noise.
TEST(ProxyBootFrame, FoundAtTheZeroBeforeTheFirstWholeFrame) {
  const auto find = [](const std::vector<std::uint8_t>& bytes) -> long {
    std::size_t start = 99;
    return find_boot_frame(bytes.data(), bytes.size(), start) ? static_cast<long>(start) : -1;
  };
  EXPECT_EQ(find({}), -1);
  EXPECT_EQ(find({0x00, 0x04, 0x11, 0x22}), -1);                    // not closed yet
  EXPECT_EQ(find({0x00, 0x03, 0x11, 0x00}), -1);                    // two bytes between: noise
  EXPECT_EQ(find({0x00, 0x04, 0x11, 0x22, 0x00}), 0);               // code byte and CRC: the shortest frame
  EXPECT_EQ(find({0x7E, 0x00, 0x01, 0x00, 0x05, 0x01, 0x02, 0x03, 0x04, 0x00}), 3);
  const std::vector<std::uint8_t> frame = {0x41, 0x42, 0x00, 0x05, 0x01, 0x02, 0x03, 0x04, 0x00, 0x00};
  EXPECT_EQ(find(frame), 2);
}

}  // namespace
}  // namespace tether::proxy
