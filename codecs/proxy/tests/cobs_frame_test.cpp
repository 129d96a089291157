// COBS and the proxy frame: the spec's vectors, COBS edge cases, resynchronisation, bounds.
#include <gtest/gtest.h>

#include <random>
#include <vector>

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
  // encode_frame stages the payload at the buffer's end and encodes forward over it: check it against
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

TEST(ProxyFrame, TooSmallBufferIsReported) {
  Bytes out(5);
  const Bytes payload(10, 1);
  EXPECT_EQ(encode_frame(ByteView(payload.data(), payload.size()), Integrity::crc16, false,
                         MutableByteView(out.data(), out.size()))
                .status(),
            Status::buffer_too_small);
}

}  // namespace
}  // namespace tether::proxy
