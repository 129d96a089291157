// The incremental envelope decoder: published vectors, every envelope error code, resynchronisation,
// chunking independence and the host's long-line capacity (reference defect B2).
#include "tether/romi/decoder.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "tether/romi/encoder.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether::romi {
namespace {

// What a frame or an error read from the decoder says (log lines apart from other frames).
enum class Kind { frame, log, error };

struct Decoded {
  Kind kind;
  Error error;
  std::string payload;
  bool manual;
  bool has_id;
  int id;
  char opcode;
};

template <size_t Capacity = kDeviceDecoderCapacity>
std::vector<Decoded> decode(const std::string& bytes, LinkCounters* counters_out = nullptr) {
  LinkCounters counters;
  Decoder<Capacity> decoder(counters);
  std::vector<Decoded> events;
  for (char c : bytes) {
    const DecodeStatus status = decoder.feed(static_cast<uint8_t>(c));
    if (status == DecodeStatus::more) continue;
    const Frame& f = decoder.frame();
    const Kind kind = status == DecodeStatus::error ? Kind::error : f.log ? Kind::log : Kind::frame;
    const Error error = status == DecodeStatus::error ? decoder.error() : Error::no_error;
    events.push_back({kind, error, std::string(reinterpret_cast<const char*>(f.payload.data()), f.payload.size()),
                      f.manual, f.has_id, f.id, f.opcode});
  }
  if (counters_out) *counters_out = counters;
  return events;
}

Error single_error(const std::string& bytes) {
  const auto events = decode(bytes);
  EXPECT_EQ(events.size(), 1u) << bytes;
  if (events.size() != 1 || events[0].kind != Kind::error) return Error::no_error;
  return events[0].error;
}

TEST(RomiEnvelope, ADefaultConstructedDecoderCountsWhereItIsToldTo) {
  // A device's decoder is default-constructed inside its zero-filled state, then pointed at its counters.
  LinkCounters counters;
  Decoder<kDeviceDecoderCapacity> decoder;
  decoder.count_into(counters);
  const std::string bytes = "junk#a:008e\r\n#e:7b00\r\n";
  for (char c : bytes) decoder.feed(static_cast<uint8_t>(c));
  EXPECT_EQ(counters.frames_ok, 1u);
  EXPECT_EQ(counters.crc_errors, 1u);
  EXPECT_EQ(counters.resyncs, 1u);
}

TEST(RomiEnvelope, ValidRequestWithIdAndCrc) {
  const auto events = decode("#M[16,\"Shutdown\"]:7bba\r\n");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::frame);
  EXPECT_EQ(events[0].payload, "M[16,\"Shutdown\"]");
  EXPECT_TRUE(events[0].has_id);
  EXPECT_EQ(events[0].id, 0x7b);
  EXPECT_EQ(events[0].opcode, 'M');
  EXPECT_FALSE(events[0].manual);
}

TEST(RomiEnvelope, ManualRequest) {
  const auto events = decode("#a[1]:xxxx\r\n");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_TRUE(events[0].manual);
  EXPECT_FALSE(events[0].has_id);
  EXPECT_EQ(events[0].payload, "a[1]");
}

TEST(RomiEnvelope, PublishedErrorVectors) {
  EXPECT_EQ(single_error("#e:7b00\r\n"), Error::crc_mismatch);
  EXPECT_EQ(single_error("#e:\r\n"), Error::invalid_id);
  EXPECT_EQ(single_error("#e\r\n"), Error::missing_metadata);
}

TEST(RomiEnvelope, EveryEnvelopeErrorCode) {
  EXPECT_EQ(single_error("#a" + std::string(80, '1') + ":xxxx\r\n"), Error::envelope_too_long);
  EXPECT_EQ(single_error("#a:7B04\r\n"), Error::invalid_id);  // uppercase hex is rejected
  EXPECT_EQ(single_error("#a:7\r\n"), Error::invalid_id);
  EXPECT_EQ(single_error("#a:7bZ4\r\n"), Error::invalid_crc);
  EXPECT_EQ(single_error("#a:7b0\r\n"), Error::invalid_crc);
  EXPECT_EQ(single_error("#a:008f\r\n"), Error::crc_mismatch);
  EXPECT_EQ(single_error("#a:008e\rX"), Error::expected_end);
  EXPECT_EQ(single_error("#a:008e1\r\n"), Error::expected_end);
  EXPECT_EQ(single_error("#a:008e\n"), Error::expected_end);
  EXPECT_EQ(single_error("#a[1]\r\n"), Error::missing_metadata);
  EXPECT_EQ(single_error("#a\n"), Error::missing_metadata);
  EXPECT_EQ(single_error("#a:xxyx\r\n"), Error::invalid_dummy_metadata);
  EXPECT_EQ(single_error("#a:x\r\n"), Error::invalid_dummy_metadata);
}

TEST(RomiEnvelope, ErrorEventsCarryTheFramesOpcodeAndIdParsedSoFar) {
  auto events = decode("#s[1,2]:2a00\r\n");  // CRC wrong, id valid
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].error, Error::crc_mismatch);
  EXPECT_EQ(events[0].opcode, 's');
  EXPECT_TRUE(events[0].has_id);
  EXPECT_EQ(events[0].id, 0x2a);
  events = decode("#s[1]:zz00\r\n");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].opcode, 's');
  EXPECT_FALSE(events[0].has_id);
  events = decode("#\r\n");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].opcode, '_');
}

TEST(RomiEnvelope, AnErrorNeverCarriesTheIdOfThePreviousFrame) {
  // Regression: a delivered frame's id stayed in the decoder and was reported with the next frame's error.
  const auto events = decode("#a:42d4\r\n#c\r\n");
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, Kind::frame);
  EXPECT_EQ(events[1].error, Error::missing_metadata);
  EXPECT_FALSE(events[1].has_id);
  EXPECT_EQ(events[1].id, 0);
}

TEST(RomiEnvelope, OversizeIsReportedExactlyOnce) {
  // Reference defect B1: the reference firmware answered an overlong frame twice.
  LinkCounters counters;
  const auto events = decode("#a[" + std::string(200, '1') + "]:xxxx\r\n", &counters);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].error, Error::envelope_too_long);
  EXPECT_EQ(counters.oversize_frames, 1u);
}

TEST(RomiEnvelope, DeviceAcceptsTheReferenceClientsLongestPayload) {
  // The reference client sends payloads of up to 58 characters (B1: its firmware accepted only 57).
  const std::string payload = "m[" + std::string(55, '1') + "]";
  ASSERT_EQ(payload.size(), kMaxDevicePayload);
  uint8_t frame[128];
  const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()), 9, frame);
  const auto events = decode(std::string(reinterpret_cast<char*>(frame), size.value()));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::frame);
  EXPECT_EQ(events[0].payload, payload);
  EXPECT_EQ(single_error("#m[" + std::string(56, '1') + "]:xxxx\r\n"), Error::envelope_too_long);
}

TEST(RomiEnvelope, HostReadsLongResponsesAndLogLines) {
  // Reference defect B2: its host rejected responses and log lines longer than 57 characters.
  const std::string text(300, 'L');
  uint8_t frame[512];
  auto size = encode_log(ByteView::from_chars(text.data(), text.size()), frame);
  auto events = decode<kHostDecoderCapacity>(std::string(reinterpret_cast<char*>(frame), size.value()));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::log);
  EXPECT_EQ(events[0].payload, text);
  const std::string body = "[0,\"" + std::string(200, 'v') + "\"]";
  size = encode_response('r', ByteView::from_chars(body.data(), body.size()), 3, frame);
  events = decode<kHostDecoderCapacity>(std::string(reinterpret_cast<char*>(frame), size.value()));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::frame);
  EXPECT_EQ(events[0].payload, "r" + body);
}

TEST(RomiEnvelope, LogTextMayContainColons) {
  const auto events = decode<kHostDecoderCapacity>("#!speed: 3 m/s, state: ok:xxxx\r\n");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::log);
  EXPECT_EQ(events[0].payload, "speed: 3 m/s, state: ok");
}

TEST(RomiEnvelope, JunkBeforeAFrameAndAHashInsideOneResynchronise) {
  LinkCounters counters;
  static const char kBytes[] = "noise\x00\xff#a:0#e:7b04\r\n";
  const std::string stream(kBytes, sizeof kBytes - 1);  // sized: the NUL inside is data
  const auto events = decode(stream, &counters);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].payload, "e");
  EXPECT_EQ(counters.resyncs, 2u);
  EXPECT_EQ(counters.frames_ok, 1u);
}

TEST(RomiEnvelope, AfterAnErrorTheRestOfTheLineIsIgnoredAndTheNextFrameDecodes) {
  const auto events = decode("#a:zz\r\n#e:7b04\r\n");
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].error, Error::invalid_id);
  EXPECT_EQ(events[1].kind, Kind::frame);
}

TEST(RomiEnvelope, CountersSeparateCauses) {
  LinkCounters counters;
  decode("#a:008f\r\n#a\r\n#a:008e\r\n", &counters);
  EXPECT_EQ(counters.crc_errors, 1u);
  EXPECT_EQ(counters.framing_errors, 1u);
  EXPECT_EQ(counters.frames_ok, 1u);
}

TEST(RomiEnvelope, RandomStreamsOfValidFramesDecodeInAnyChunking) {
  // The decoder is byte-wise, so chunking cannot matter; what this guards is state carried across
  // frames: every frame of a long random stream, with junk between, must come out intact.
  auto generator = tether::testing::seeded_generator(21);
  std::string stream;
  std::vector<std::string> payloads;
  for (int i = 0; i < 300; ++i) {
    if (generator() % 4 == 0) stream += "junk\r\n";
    RequestBuilder builder("aZ9?"[generator() % 4]);
    const int args = static_cast<int>(generator() % 5);
    for (int a = 0; a < args; ++a) builder.add_int(static_cast<int32_t>(generator() % 65536) - 32768);
    if (generator() % 3 == 0) builder.add_string(ByteView::from_literal("Hello (world) 42"));
    ASSERT_EQ(builder.error(), Error::no_error);
    payloads.emplace_back(reinterpret_cast<const char*>(builder.payload().data()), builder.payload().size());
    uint8_t frame[128];
    const auto size = encode_request(builder.payload(), static_cast<uint8_t>(i), frame);
    stream.append(reinterpret_cast<char*>(frame), size.value());
  }
  const auto events = decode(stream);
  ASSERT_EQ(events.size(), payloads.size());
  for (size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].payload, payloads[i]);
    EXPECT_EQ(events[i].id, static_cast<int>(i % 256));
  }
}

TEST(RomiEnvelope, ResetDropsTheFrameInProgress) {
  LinkCounters counters;
  Decoder<kDeviceDecoderCapacity> decoder(counters);
  for (char c : std::string("#a[1,2")) decoder.feed(static_cast<uint8_t>(c));
  EXPECT_TRUE(decoder.in_frame());
  decoder.reset();
  EXPECT_FALSE(decoder.in_frame());
  for (char c : std::string("]:xxxx\r\n")) {
    EXPECT_EQ(decoder.feed(static_cast<uint8_t>(c)), DecodeStatus::more);
  }
}

TEST(RomiEnvelope, AbandonDropsTheFrameAndKeepsItsOpcodeWithoutAnId) {
  LinkCounters counters;
  Decoder<kDeviceDecoderCapacity> decoder(counters);
  // Dropped at its '\r' (the id read, only the '\n' missing): the frame says its opcode, no id.
  for (char c : std::string("#e:7b04\r")) decoder.feed(static_cast<uint8_t>(c));
  ASSERT_TRUE(decoder.awaiting_end());
  EXPECT_EQ(decoder.frame().id, 0x7b);
  decoder.abandon();
  EXPECT_FALSE(decoder.in_frame());
  EXPECT_EQ(decoder.frame().opcode, 'e');
  EXPECT_EQ(decoder.frame().id, 0);
  EXPECT_FALSE(decoder.frame().has_id);
  EXPECT_TRUE(decoder.frame().payload.empty());
  EXPECT_EQ(decoder.feed(static_cast<uint8_t>('\n')), DecodeStatus::more);  // nothing completes
  // A log line or a frame without an opcode character yet: '_'.
  for (const std::string partial : {"#!lo", "#", "#[1"}) {
    for (char c : partial) decoder.feed(static_cast<uint8_t>(c));
    decoder.abandon();
    EXPECT_EQ(decoder.frame().opcode, '_') << partial;
    EXPECT_FALSE(decoder.frame().log) << partial;
  }
  // The next frame decodes.
  for (char c : std::string("#e:7b04\r")) EXPECT_EQ(decoder.feed(static_cast<uint8_t>(c)), DecodeStatus::more);
  EXPECT_EQ(decoder.feed(static_cast<uint8_t>('\n')), DecodeStatus::frame);
  EXPECT_EQ(decoder.frame().opcode, 'e');
  EXPECT_EQ(decoder.frame().id, 0x7b);
}

TEST(RomiEnvelope, SpanFeedingStopsAtEachEventAndMatchesByteFeeding) {
  // feed(bytes) stops after the byte that completes a frame or an error, so a read loop sees every
  // event, in order, whatever the read sizes: the same events as byte-at-a-time feeding.
  const std::string stream = "junk#a:008f\r\n#e:7b04\r\n#!log: ok:xxxx\r\n#a\r\n#e:7b04\r\n";
  const auto expected = decode<kHostDecoderCapacity>(stream);
  ASSERT_EQ(expected.size(), 5u);
  for (size_t chunk = 1; chunk <= stream.size(); ++chunk) {
    LinkCounters counters;
    Decoder<kHostDecoderCapacity> decoder(counters);
    std::vector<Decoded> events;
    for (size_t at = 0; at < stream.size(); at += chunk) {
      ByteView rest = ByteView::from_chars(stream.data() + at, std::min(chunk, stream.size() - at));
      while (!rest.empty()) {
        const FeedResult result = decoder.feed(rest);
        ASSERT_GE(result.consumed, 1u);
        ASSERT_LE(result.consumed, rest.size());
        rest = rest.subview(result.consumed);
        if (result.status == DecodeStatus::more) {
          ASSERT_TRUE(rest.empty());  // `more` only when the whole span was used
          continue;
        }
        const Frame& f = decoder.frame();
        const Kind kind = result.status == DecodeStatus::error ? Kind::error : f.log ? Kind::log : Kind::frame;
        events.push_back({kind, result.status == DecodeStatus::error ? decoder.error() : Error::no_error,
                          std::string(reinterpret_cast<const char*>(f.payload.data()), f.payload.size()), f.manual,
                          f.has_id, f.id, f.opcode});
      }
    }
    ASSERT_EQ(events.size(), expected.size()) << "chunk " << chunk;
    for (size_t i = 0; i < events.size(); ++i) {
      EXPECT_EQ(events[i].kind, expected[i].kind) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].error, expected[i].error) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].payload, expected[i].payload) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].id, expected[i].id) << "chunk " << chunk << " event " << i;
    }
  }
}

// `stream` through feed(bytes) in reads of `chunk` bytes, every event as decode() records it.
template <size_t Capacity>
std::vector<Decoded> decode_in_chunks(const std::string& stream, size_t chunk, LinkCounters& counters) {
  Decoder<Capacity> decoder(counters);
  std::vector<Decoded> events;
  for (size_t at = 0; at < stream.size(); at += chunk) {
    ByteView rest = ByteView::from_chars(stream.data() + at, std::min(chunk, stream.size() - at));
    while (!rest.empty()) {
      const FeedResult result = decoder.feed(rest);
      EXPECT_GE(result.consumed, 1u);
      if (result.consumed == 0) return events;
      rest = rest.subview(result.consumed);
      if (result.status == DecodeStatus::more) continue;
      const Frame& f = decoder.frame();
      const Kind kind = result.status == DecodeStatus::error ? Kind::error : f.log ? Kind::log : Kind::frame;
      events.push_back({kind, result.status == DecodeStatus::error ? decoder.error() : Error::no_error,
                        std::string(reinterpret_cast<const char*>(f.payload.data()), f.payload.size()), f.manual,
                        f.has_id, f.id, f.opcode});
    }
  }
  return events;
}

std::string request_frame(const std::string& payload, uint8_t id) {
  uint8_t frame[128];
  const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()), id, frame);
  return std::string(reinterpret_cast<const char*>(frame), size.ok() ? size.value() : 0);
}

TEST(RomiEnvelope, SpanFeedingMatchesByteFeedingAtTheCapacityAndOnEveryError) {
  // feed(bytes) takes a frame's body in its own loop, bounded by the room left: every chunking
  // gives byte feeding's events and counters, for a frame that fills the device's decoder exactly, one a
  // byte longer, colons in a log line, a '#' inside a frame, a CRC mismatch, a manual frame, '\n' without
  // '\r', bad metadata, junk between frames.
  const std::string fits = request_frame("m[" + std::string(55, '1') + "]", 0x3c);  // 58 + 5 = 63 bytes
  const std::string too_long = request_frame("m[" + std::string(56, '1') + "]", 0x3d);
  const std::string stream = fits + too_long + "#!a: b: c:xxxx\r\n" + "#a[1#e:7b04\r\n" + "#e:7b05\r\n" +
                             "junk" + "#a[2]:xxxx\r\n" + "#e:7b04\n" + "#e:7\r\n" + "#e:7b04x\r\n" + fits;
  LinkCounters expected_counters;
  const auto expected = decode<kDeviceDecoderCapacity>(stream, &expected_counters);
  ASSERT_EQ(expected.size(), 10u);
  EXPECT_EQ(expected.front().kind, Kind::frame);
  EXPECT_EQ(expected[1].error, Error::envelope_too_long);
  for (size_t chunk = 1; chunk <= stream.size(); ++chunk) {
    LinkCounters counters;
    const auto events = decode_in_chunks<kDeviceDecoderCapacity>(stream, chunk, counters);
    ASSERT_EQ(events.size(), expected.size()) << "chunk " << chunk;
    for (size_t i = 0; i < events.size(); ++i) {
      EXPECT_EQ(events[i].kind, expected[i].kind) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].error, expected[i].error) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].payload, expected[i].payload) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].manual, expected[i].manual) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].has_id, expected[i].has_id) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].id, expected[i].id) << "chunk " << chunk << " event " << i;
      EXPECT_EQ(events[i].opcode, expected[i].opcode) << "chunk " << chunk << " event " << i;
    }
    EXPECT_EQ(counters.frames_ok, expected_counters.frames_ok) << "chunk " << chunk;
    EXPECT_EQ(counters.crc_errors, expected_counters.crc_errors) << "chunk " << chunk;
    EXPECT_EQ(counters.framing_errors, expected_counters.framing_errors) << "chunk " << chunk;
    EXPECT_EQ(counters.oversize_frames, expected_counters.oversize_frames) << "chunk " << chunk;
    EXPECT_EQ(counters.resyncs, expected_counters.resyncs) << "chunk " << chunk;
  }
}

TEST(RomiEnvelope, BodyRunsDecodeExactlyLikeSingleBytes) {
  // A device's byte loop: feed_body_run over a batch, then feed_special for the byte that ended the run.
  // Same events and counters as byte-at-a-time feeding, on random streams of valid frames, damaged ones,
  // overlong ones (the run must stop at the buffer's end) and junk, cut into random batches.
  auto generator = tether::testing::seeded_generator(22);
  const std::string alphabet = "#\r\n:::xx0123456789abcdef[],-\"! aeZ?";
  for (int round = 0; round < 200; ++round) {
    std::string stream;
    while (stream.size() < 400) {
      const auto pick = generator() % 4;
      if (pick == 0) {
        for (auto n = generator() % 90; n > 0; --n) stream += alphabet[generator() % alphabet.size()];
      } else {
        std::string payload(1, "aeZ?"[generator() % 4]);
        if (pick == 1) payload += "[" + std::to_string(generator() % 70000) + ",\"a:b\"]";
        if (pick == 2) payload += std::string(generator() % 70, '9');  // around the 63-byte capacity
        uint8_t frame[128];
        const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()),
                                         static_cast<uint8_t>(generator()), frame);
        stream.append(reinterpret_cast<char*>(frame), size.value());
      }
    }
    LinkCounters expected_counters;
    const auto expected = decode(stream, &expected_counters);
    LinkCounters counters;
    Decoder<kDeviceDecoderCapacity> decoder(counters);
    std::vector<Decoded> events;
    const auto* bytes = reinterpret_cast<const uint8_t*>(stream.data());
    for (size_t at = 0; at < stream.size();) {
      uint8_t left = static_cast<uint8_t>(std::min<size_t>(1 + generator() % 16, stream.size() - at));
      while (left != 0) {
        const uint8_t run = decoder.feed_body_run(bytes + at, left);
        ASSERT_LE(run, left);
        at += run;
        left = static_cast<uint8_t>(left - run);
        if (left == 0) break;
        const DecodeStatus status = decoder.feed_special(bytes[at++]);
        --left;
        if (status == DecodeStatus::more) continue;
        const Frame& f = decoder.frame();
        const Kind kind = status == DecodeStatus::error ? Kind::error : f.log ? Kind::log : Kind::frame;
        events.push_back({kind, status == DecodeStatus::error ? decoder.error() : Error::no_error,
                          std::string(reinterpret_cast<const char*>(f.payload.data()), f.payload.size()), f.manual,
                          f.has_id, f.id, f.opcode});
      }
    }
    ASSERT_EQ(events.size(), expected.size()) << "round " << round << ": " << stream;
    for (size_t i = 0; i < events.size(); ++i) {
      EXPECT_EQ(events[i].kind, expected[i].kind) << "round " << round << " event " << i;
      EXPECT_EQ(events[i].error, expected[i].error) << "round " << round << " event " << i;
      EXPECT_EQ(events[i].payload, expected[i].payload) << "round " << round << " event " << i;
      EXPECT_EQ(events[i].has_id, expected[i].has_id) << "round " << round << " event " << i;
      EXPECT_EQ(events[i].id, expected[i].id) << "round " << round << " event " << i;
      EXPECT_EQ(events[i].opcode, expected[i].opcode) << "round " << round << " event " << i;
    }
    EXPECT_EQ(counters.frames_ok, expected_counters.frames_ok);
    EXPECT_EQ(counters.oversize_frames, expected_counters.oversize_frames);
    EXPECT_EQ(counters.framing_errors, expected_counters.framing_errors);
    EXPECT_EQ(counters.crc_errors, expected_counters.crc_errors);
    EXPECT_EQ(counters.resyncs, expected_counters.resyncs);
    if (HasFailure()) return;
  }
}

}  // namespace
}  // namespace tether::romi
