// The hand-written envelope (envelope.hpp) against libprotobuf's classes of tether_rpc.proto: the
// HostMessages it writes are libprotobuf's bytes, its frames proxy::encode_frame's, and it reads a
// DeviceMessage exactly when libprotobuf does, with the same fields; its frame reader reports what
// proxy::Decoder does (randomized: RANDOM_SEED repeats a run).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "envelope_reference.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether/testing/random_seed.hpp"

namespace {

using namespace tether;
using namespace tether::rpc;
using rpc::envelope_reference::compare_decoders;
using rpc::envelope_reference::hex;

std::string str(std::initializer_list<int> bytes) {
  std::string out;
  for (const int byte : bytes) out += static_cast<char>(byte);
  return out;
}

// Random values across the varint size classes.
std::uint64_t random_value(std::mt19937_64& rng) {
  switch (rng() % 5) {
    case 0: return 0;
    case 1: return rng() % 0x80;
    case 2: return rng() % 0x4000;
    case 3: return static_cast<std::uint32_t>(rng());
    default: return rng();
  }
}

std::string random_bytes(std::mt19937_64& rng, std::size_t max) {
  std::string out(rng() % (max + 1), '\0');
  for (char& c : out) c = static_cast<char>(rng() % 4 == 0 ? 0 : rng());  // zeros for COBS
  return out;
}

TEST(RpcEnvelope, HostMessagesAreLibprotobufsBytes) {
  std::mt19937_64 rng = tether::testing::seeded_generator(1);
  const envelope::HostBody bodies[] = {envelope::HostBody::none,  envelope::HostBody::hello, envelope::HostBody::call,
                                       envelope::HostBody::open,  envelope::HostBody::close, envelope::HostBody::ping,
                                       envelope::HostBody::reset};
  for (int round = 0; round < 20000; ++round) {
    std::string request = random_bytes(rng, round % 10 == 0 ? 400 : 64);
    if (round % 20 == 1) {  // long runs without a zero: COBS blocks of 254 bytes, one ending the frame
      request.assign(240 + rng() % 300, '\0');
      for (char& c : request) c = static_cast<char>(1 + rng() % 255);
    }
    envelope::HostMessage message;
    message.id = static_cast<std::uint32_t>(random_value(rng));
    message.body = bodies[rng() % 7];
    message.method = static_cast<std::uint32_t>(random_value(rng));
    message.request = ByteView::from_chars(request.data(), request.size());
    message.period_ms = static_cast<std::uint32_t>(random_value(rng));
    message.stream = static_cast<std::uint32_t>(random_value(rng));
    const std::string expected = rpc::envelope_reference::to_libprotobuf(message).SerializeAsString();

    std::string encoded(envelope::encoded_size(message), '\0');
    ASSERT_EQ(envelope::encode(message, reinterpret_cast<std::uint8_t*>(encoded.data())), encoded.size());
    ASSERT_EQ(hex(encoded), hex(expected)) << "round " << round;

    std::string frame(proxy::max_frame_size(expected.size()), '\0');
    const Result<size_t> size =
        proxy::encode_frame(ByteView::from_chars(expected.data(), expected.size()), proxy::Integrity::crc16, true,
                            MutableByteView(reinterpret_cast<std::uint8_t*>(frame.data()), frame.size()));
    ASSERT_TRUE(size.ok());
    frame.resize(size.value());
    std::string written = "recycled frame string with old bytes in it";
    envelope::write_frame(message, written);
    ASSERT_EQ(hex(written), hex(frame)) << "round " << round;
  }
}

// Every length around COBS's 254-byte block: a block ending exactly at the frame's end included.
TEST(RpcEnvelope, FramesAroundTheCobsBlock) {
  for (std::size_t length = 200; length < 560; ++length) {
    std::string request(length, '\x5a');
    envelope::HostMessage message;
    message.id = 0x01020304;
    message.body = envelope::HostBody::call;
    message.method = 1;
    message.request = ByteView::from_chars(request.data(), request.size());
    const std::string payload = rpc::envelope_reference::to_libprotobuf(message).SerializeAsString();
    std::string frame(proxy::max_frame_size(payload.size()), '\0');
    const Result<size_t> size =
        proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16, true,
                            MutableByteView(reinterpret_cast<std::uint8_t*>(frame.data()), frame.size()));
    ASSERT_TRUE(size.ok());
    frame.resize(size.value());
    std::string written;
    envelope::write_frame(message, written);
    ASSERT_EQ(hex(written), hex(frame)) << "request of " << length << " bytes";
  }
}

TEST(RpcEnvelope, HostMessageExamples) {
  envelope::HostMessage call;
  call.id = 0x12345678;
  call.body = envelope::HostBody::call;
  call.method = 0;  // proto3: a zero is not written
  const std::string request = str({0x08, 0x02});
  call.request = ByteView::from_chars(request.data(), request.size());
  std::string out(envelope::encoded_size(call), '\0');
  envelope::encode(call, reinterpret_cast<std::uint8_t*>(out.data()));
  EXPECT_EQ(hex(out), hex(str({0x08, 0xf8, 0xac, 0xd1, 0x91, 0x01, 0x1a, 0x04, 0x12, 0x02, 0x08, 0x02})));

  envelope::HostMessage ping;  // an empty body is still written: it is the oneof's choice
  ping.body = envelope::HostBody::ping;
  out.assign(envelope::encoded_size(ping), '\0');
  envelope::encode(ping, reinterpret_cast<std::uint8_t*>(out.data()));
  EXPECT_EQ(hex(out), hex(str({0x32, 0x00})));
}

// Random DeviceMessages as a device, a newer device or a broken one might write them: every known field,
// repeated; unknown fields of every wire type (groups nested); known numbers with other wire types;
// overlong varints and tags; then, for some, a mutation.
class Generator {
 public:
  explicit Generator(std::mt19937_64& rng) : rng_(rng) {}

  std::string payload() {
    std::string out;
    const int entries = static_cast<int>(rng_() % 5);
    for (int i = 0; i < entries; ++i) {
      if (rng_() % 4 == 0) {
        unknown_field(out, 0);
      } else {
        const auto field = static_cast<std::uint8_t>(1 + rng_() % 6);
        length_delimited(out, field, body(field));
      }
    }
    if (rng_() % 3 == 0) mutate(out);
    return out;
  }

 private:
  void varint(std::string& out, std::uint64_t value, unsigned max_bytes = 10) {
    std::string bytes;
    do {
      bytes += static_cast<char>((value & 0x7F) | 0x80);
      value >>= 7;
    } while (value != 0);
    // Sometimes overlong (still within max_bytes), once in a while longer than allowed.
    if (rng_() % 8 == 0) {
      const std::size_t longer = bytes.size() + rng_() % (max_bytes + 2 - std::min<std::size_t>(bytes.size(), max_bytes));
      while (bytes.size() < longer) bytes += static_cast<char>(0x80);
    }
    bytes.back() = static_cast<char>(bytes.back() & 0x7F);
    out += bytes;
  }
  void tag(std::string& out, std::uint32_t field, unsigned wire_type) { varint(out, field << 3 | wire_type, 5); }
  void length_delimited(std::string& out, std::uint32_t field, const std::string& bytes) {
    tag(out, field, 2);
    varint(out, bytes.size(), 5);
    out += bytes;
  }
  std::uint32_t field_number() {
    switch (rng_() % 4) {
      case 0: return static_cast<std::uint32_t>(rng_() % 16);  // 0 is invalid
      case 1: return static_cast<std::uint32_t>(1 + rng_() % 5);
      case 2: return static_cast<std::uint32_t>(16 + rng_() % 2048);
      default: return static_cast<std::uint32_t>(1 + rng_() % ((1u << 29) - 1));
    }
  }
  void unknown_field(std::string& out, int depth) {
    const std::uint32_t field = field_number();
    const unsigned wire_type = static_cast<unsigned>(rng_() % 16 == 0 ? 6 + rng_() % 2 : rng_() % 6);
    switch (wire_type) {
      case 0:
        tag(out, field, 0);
        varint(out, random_value(rng_));
        break;
      case 1:
        tag(out, field, 1);
        for (int i = 0; i < 8; ++i) out += static_cast<char>(rng_());
        break;
      case 2:
        length_delimited(out, field, random_bytes(rng_, 12));
        break;
      case 3: {
        tag(out, field, 3);
        const int inner = depth < 4 ? static_cast<int>(rng_() % 3) : 0;
        for (int i = 0; i < inner; ++i) unknown_field(out, depth + 1);
        tag(out, rng_() % 16 == 0 ? field_number() : field, 4);
        break;
      }
      case 4:  // a stray end-group tag
        tag(out, field, 4);
        break;
      case 5:
        tag(out, field, 5);
        for (int i = 0; i < 4; ++i) out += static_cast<char>(rng_());
        break;
      default:
        tag(out, field, wire_type);
        out += random_bytes(rng_, 4);
        break;
    }
  }
  // The body's message of DeviceMessage field `field`: its own fields (with their wire types, or another one).
  std::string body(std::uint8_t field) {
    // (field number, wire type) of each known field of the body's message.
    static const std::vector<std::vector<std::pair<std::uint32_t, unsigned>>> kFields = {
        {{1, 0}, {2, 0}},                  // Ack
        {{1, 0}, {2, 2}},                  // Reply
        {{1, 0}, {2, 0}, {3, 2}},          // DeviceError
        {{1, 0}, {2, 0}, {3, 2}},          // StreamMessage
        {{1, 1}, {2, 0}, {3, 0}, {4, 0}},  // DeviceHello
        {{1, 0}},                          // ResetEvent
    };
    const auto& fields = kFields[field - 1u];
    std::string out;
    const int entries = static_cast<int>(rng_() % 6);
    for (int i = 0; i < entries; ++i) {
      if (rng_() % 5 == 0) {
        unknown_field(out, 0);
        continue;
      }
      auto [number, wire_type] = fields[rng_() % fields.size()];
      if (rng_() % 10 == 0) wire_type = rng_() % 2 == 0 ? 5u : static_cast<unsigned>(rng_() % 3);
      switch (wire_type) {
        case 0:
          tag(out, number, 0);
          varint(out, random_value(rng_));
          break;
        case 1:
          tag(out, number, 1);
          for (int b = 0; b < 8; ++b) out += static_cast<char>(rng_());
          break;
        case 2:
          if (field == 3 && rng_() % 2 == 0) {
            length_delimited(out, number, text());
          } else {
            length_delimited(out, number, random_bytes(rng_, 20));
          }
          break;
        default:
          tag(out, number, 5);
          for (int b = 0; b < 4; ++b) out += static_cast<char>(rng_());
          break;
      }
    }
    return out;
  }
  // A DeviceError text: UTF-8, or not (stray continuation bytes, overlong forms, surrogates, truncation).
  std::string text() {
    static const std::vector<std::string> kPieces = {"joint", " ", "\xc3\xa9", "\xe2\x82\xac", "\xf0\x9f\x98\x80",
                                                     "\x80", "\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80",
                                                     "\xe2\x82", "\xff", std::string(1, '\0')};
    std::string out;
    const int pieces = static_cast<int>(rng_() % 5);
    for (int i = 0; i < pieces; ++i) out += kPieces[rng_() % kPieces.size()];
    return out;
  }
  void mutate(std::string& out) {
    if (out.empty()) {
      out = random_bytes(rng_, 6);
      return;
    }
    switch (rng_() % 4) {
      case 0:
        out.resize(rng_() % out.size());
        break;
      case 1:
        out[rng_() % out.size()] = static_cast<char>(rng_());
        break;
      case 2:
        out.insert(rng_() % out.size(), random_bytes(rng_, 3));
        break;
      default:
        out += random_bytes(rng_, 3);
        break;
    }
  }

  std::mt19937_64& rng_;
};

TEST(RpcEnvelope, DecodesExactlyWhatLibprotobufDoes) {
  std::mt19937_64 rng = tether::testing::seeded_generator(2);
  Generator generator(rng);
  int accepted = 0;
  constexpr int kRounds = 50000;
  for (int round = 0; round < kRounds; ++round) {
    const std::string payload = generator.payload();
    const std::string difference = compare_decoders(payload);
    ASSERT_EQ(difference, "") << "round " << round;
    envelope::DeviceMessage out;
    if (envelope::decode(ByteView::from_chars(payload.data(), payload.size()), out) == envelope::DecodeError::none) {
      ++accepted;
    }
  }
  // Both outcomes are well represented (the generator is not testing one side only).
  EXPECT_GT(accepted, kRounds / 5);
  EXPECT_LT(accepted, kRounds * 4 / 5);
}

TEST(RpcEnvelope, ReadsWhatLibprotobufWrites) {
  std::mt19937_64 rng = tether::testing::seeded_generator(3);
  for (int round = 0; round < 20000; ++round) {
    wire::DeviceMessage message;
    const auto value = [&] { return static_cast<std::uint32_t>(random_value(rng)); };
    switch (rng() % 7) {
      case 0: message.mutable_ack()->set_id(value()); message.mutable_ack()->set_refused(rng() % 2 == 0); break;
      case 1: message.mutable_reply()->set_call(value()); message.mutable_reply()->set_reply(random_bytes(rng, 200)); break;
      case 2:
        message.mutable_error()->set_call(value());
        message.mutable_error()->set_code(value());
        message.mutable_error()->set_text(std::string(rng() % 40, 'x'));
        break;
      case 3:
        message.mutable_stream()->set_stream(value());
        message.mutable_stream()->set_seq(value());
        message.mutable_stream()->set_message(random_bytes(rng, 200));
        break;
      case 4:
        message.mutable_hello()->set_schema_hash(random_value(rng));
        message.mutable_hello()->set_session(value());
        message.mutable_hello()->set_max_payload(value());
        message.mutable_hello()->set_methods(value());
        break;
      case 5: message.mutable_reset()->set_session(value()); break;
      default: break;
    }
    const std::string payload = message.SerializeAsString();
    ASSERT_EQ(compare_decoders(payload), "") << message.ShortDebugString();
  }
}

// The rules one by one: what libprotobuf does, and the reason envelope::decode gives when it refuses.
TEST(RpcEnvelope, DecodeRules) {
  const auto decode = [](const std::string& payload, envelope::DeviceMessage& out) {
    EXPECT_EQ(compare_decoders(payload), "");
    return envelope::decode(ByteView::from_chars(payload.data(), payload.size()), out);
  };
  envelope::DeviceMessage out;
  // Empty: a message with no body.
  EXPECT_EQ(decode("", out), envelope::DecodeError::none);
  EXPECT_EQ(out.body, envelope::DeviceBody::none);
  // Fields in any order, the last scalar wins, a repeated body message merges.
  EXPECT_EQ(decode(str({0x0a, 0x02, 0x10, 0x01, 0x0a, 0x04, 0x08, 0x05, 0x08, 0x07}), out), envelope::DecodeError::none);
  EXPECT_EQ(out.body, envelope::DeviceBody::ack);
  EXPECT_EQ(out.ack.id, 7u);
  EXPECT_TRUE(out.ack.refused);
  // Another member of the oneof replaces the one before (its fields start from zero).
  EXPECT_EQ(decode(str({0x0a, 0x02, 0x08, 0x05, 0x32, 0x00}), out), envelope::DecodeError::none);
  EXPECT_EQ(out.body, envelope::DeviceBody::reset);
  EXPECT_EQ(out.ack.id, 0u);
  // Unknown fields of every wire type, and a known number with another wire type, are skipped.
  EXPECT_EQ(decode(str({0x12, 0x0f, 0x15, 1, 2, 3, 4, 0x0b, 0x10, 0x01, 0x0c, 0x08, 0x09, 0x78, 0x00, 0x08, 0x2a}), out),
            envelope::DecodeError::none);
  EXPECT_EQ(out.body, envelope::DeviceBody::reply);
  EXPECT_EQ(out.reply.call, 42u);
  // A 10-byte varint keeps its low bits; 11 bytes are refused.
  EXPECT_EQ(decode(str({0x32, 0x0b, 0x08, 0x81, 0x80, 0x80, 0x80, 0x90, 0x80, 0x80, 0x80, 0x80, 0x7f}), out),
            envelope::DecodeError::none);
  EXPECT_EQ(out.reset.session, 1u);
  EXPECT_EQ(decode(str({0x32, 0x0c, 0x08, 0x81, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x00}), out),
            envelope::DecodeError::bad_varint);
  // Truncation, inside the body or past it.
  EXPECT_EQ(decode(str({0x0a, 0x03, 0x08, 0x01}), out), envelope::DecodeError::truncated);
  EXPECT_EQ(decode(str({0x0a, 0x02, 0x12, 0x05, 0x00}), out), envelope::DecodeError::truncated);
  // Field number 0, wire types 6 and 7.
  EXPECT_EQ(decode(str({0x02, 0x00}), out), envelope::DecodeError::bad_tag);
  EXPECT_EQ(decode(str({0x0e}), out), envelope::DecodeError::bad_tag);
  EXPECT_EQ(decode(str({0x0a, 0x01, 0x0f}), out), envelope::DecodeError::bad_tag);
  // A length of 2 GiB.
  EXPECT_EQ(decode(str({0x12, 0x80, 0x80, 0x80, 0x80, 0x08}), out), envelope::DecodeError::bad_length);
  // Groups: an end tag of another field, a stray end tag, a group left open.
  EXPECT_EQ(decode(str({0x0b, 0x14}), out), envelope::DecodeError::unexpected_end_group);
  EXPECT_EQ(decode(str({0x0c}), out), envelope::DecodeError::unexpected_end_group);
  EXPECT_EQ(decode(str({0x0a, 0x01, 0x0b}), out), envelope::DecodeError::unterminated_group);
  EXPECT_STREQ(envelope::describe(envelope::DecodeError::truncated), "a field runs past the end of its message");
}

// libprotobuf's recursion limit: 100 levels of messages and groups.
TEST(RpcEnvelope, NestingLimit) {
  const auto groups = [](int depth) { return std::string(static_cast<std::size_t>(depth), '\x0b') + std::string(static_cast<std::size_t>(depth), '\x0c'); };
  envelope::DeviceMessage out;
  for (const int depth : {99, 100, 101}) {
    const std::string top = groups(depth);
    EXPECT_EQ(compare_decoders(top), "") << depth;
    EXPECT_EQ(envelope::decode(ByteView::from_chars(top.data(), top.size()), out) == envelope::DecodeError::none,
              depth <= 100);
    // Inside the body's message (one level already).
    std::string inner = groups(depth);
    std::string body = str({0x0a});
    std::uint64_t size = inner.size();
    while (size >= 0x80) {
      body += static_cast<char>((size & 0x7F) | 0x80);
      size >>= 7;
    }
    body += static_cast<char>(size);
    body += inner;
    EXPECT_EQ(compare_decoders(body), "") << depth;
    const envelope::DecodeError error = envelope::decode(ByteView::from_chars(body.data(), body.size()), out);
    EXPECT_EQ(error == envelope::DecodeError::none, depth <= 99) << depth;
    if (depth > 99) {
      EXPECT_EQ(error, envelope::DecodeError::too_deep);
    }
  }
}

// A text that is not UTF-8 is kept, escaped, as proxy::parse_device_message keeps it.
TEST(RpcEnvelope, DeviceTextNotUtf8) {
  const std::string payload = str({0x1a, 0x07, 0x10, 0x2a, 0x1a, 0x03, 'o', 0xff, 'k'});
  ASSERT_EQ(compare_decoders(payload), "");
  envelope::DeviceMessage out;
  ASSERT_EQ(envelope::decode(ByteView::from_chars(payload.data(), payload.size()), out), envelope::DecodeError::none);
  EXPECT_FALSE(envelope::text_is_utf8(out.error.text));
  EXPECT_EQ(envelope::device_text(out.error.text), "o\\xffk");
  EXPECT_EQ(out.error.code, 42u);
}

}  // namespace

// --- FrameReader: proxy::Decoder's frames, errors and counters ------------------------------------------

// Everything a link may deliver: frames (payloads up to past the bound, zeros included), frames with a
// byte changed (a zero splits them), cut short or without their delimiter, garbage, lone delimiters.
std::string random_link_bytes(std::mt19937_64& rng, int pieces) {
  std::string stream;
  for (int piece = 0; piece < pieces; ++piece) {
    const unsigned kind = static_cast<unsigned>(rng() % 10);
    if (kind == 8) {
      stream += random_bytes(rng, 40);
      continue;
    }
    if (kind == 9) {
      stream.append(1 + rng() % 3, '\0');
      continue;
    }
    const std::size_t size = rng() % 4 == 0 ? rng() % 300 : rng() % 40;
    std::string payload;
    for (std::size_t i = 0; i < size; ++i) {
      payload += static_cast<char>(rng() % 4 == 0 ? 0 : rng() % 256);
    }
    std::string frame(proxy::max_frame_size(payload.size()), '\0');
    const Result<size_t> written =
        proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16, rng() % 2 == 0,
                            MutableByteView(reinterpret_cast<std::uint8_t*>(frame.data()), frame.size()));
    frame.resize(written.ok() ? written.value() : 0);
    if (kind == 5 && !frame.empty()) frame[rng() % frame.size()] = static_cast<char>(rng() % 256);
    if (kind == 6 && frame.size() > 1) frame.resize(1 + rng() % (frame.size() - 1));
    if (kind == 7 && !frame.empty()) frame.pop_back();
    stream += frame;
  }
  return stream;
}

// What a decoder reports for `stream` delivered in `chunks`: each frame's payload or error, and its
// counters after each chunk.
template <typename Decoder>
std::vector<std::string> decode_events(Decoder& decoder, const LinkCounters& counters, const std::string& stream,
                                       const std::vector<std::size_t>& chunks) {
  std::vector<std::string> events;
  std::size_t at = 0;
  for (const std::size_t chunk : chunks) {
    ByteView input = ByteView::from_chars(stream.data() + at, chunk);
    at += chunk;
    while (!input.empty()) {
      const FeedResult fed = decoder.feed(input);
      input = ByteView(input.data() + fed.consumed, input.size() - fed.consumed);
      if (fed.status == DecodeStatus::frame) {
        const ByteView frame = decoder.frame();
        events.push_back("frame " + hex(std::string(reinterpret_cast<const char*>(frame.data()), frame.size())));
      } else if (fed.status == DecodeStatus::error) {
        events.push_back("error " + std::string(proxy::describe(decoder.error())));
      }
    }
    events.push_back("counters ok " + std::to_string(counters.frames_ok) + " crc " + std::to_string(counters.crc_errors) +
                     " framing " + std::to_string(counters.framing_errors) + " oversize " +
                     std::to_string(counters.oversize_frames) + " resyncs " + std::to_string(counters.resyncs));
  }
  return events;
}

TEST(RpcFrameReader, ReportsWhatTheProxyDecoderReportsInAnyChunking) {
  std::mt19937_64 rng = tether::testing::seeded_generator(4);
  for (int round = 0; round < 300; ++round) {
    const std::string stream = random_link_bytes(rng, 1 + static_cast<int>(rng() % 12));
    std::vector<std::size_t> chunks;  // whole, byte by byte, or in random reads
    const unsigned split = static_cast<unsigned>(rng() % 3);
    for (std::size_t at = 0; at < stream.size();) {
      const std::size_t chunk = split == 0 ? stream.size() : split == 1 ? 1 : 1 + rng() % 64;
      chunks.push_back(std::min(chunk, stream.size() - at));
      at += chunks.back();
    }
    LinkCounters reference_counters;
    proxy::Decoder<kMaxPayload> reference(proxy::Integrity::crc16, reference_counters);
    LinkCounters counters;
    envelope::FrameReader<kMaxPayload> reader(counters);
    ASSERT_EQ(decode_events(reader, counters, stream, chunks), decode_events(reference, reference_counters, stream, chunks))
        << "stream " << hex(stream) << " in " << chunks.size() << " reads";
  }
}

TEST(RpcFrameReader, WholeFrameVerdicts) {
  std::uint8_t out[8];
  std::size_t size = 0;
  const auto verdict = [&](const std::string& encoded, std::size_t capacity) {
    return envelope::read_whole_frame(ByteView::from_chars(encoded.data(), encoded.size()), out, capacity, size);
  };
  // 0xFFFF is the CRC-16/MCRF4XX of no bytes: an empty payload.
  EXPECT_EQ(verdict(str({0x03, 0xFF, 0xFF}), 8), envelope::WholeFrame::frame);
  EXPECT_EQ(size, 2u);
  EXPECT_EQ(verdict(str({0x03, 0xFF, 0xFE}), 8), envelope::WholeFrame::crc_mismatch);
  EXPECT_EQ(verdict(str({0x01}), 8), envelope::WholeFrame::too_short);
  EXPECT_EQ(verdict(str({0x02, 0xFF}), 8), envelope::WholeFrame::too_short);
  EXPECT_EQ(verdict(str({0x05, 0xFF, 0xFF}), 8), envelope::WholeFrame::bad_cobs);
  EXPECT_EQ(verdict(str({0x05, 0xFF, 0xFF}), 1), envelope::WholeFrame::too_long);  // overflow comes first
  EXPECT_EQ(verdict(str({0x03, 0xFF, 0xFF, 0x01}), 2), envelope::WholeFrame::too_long);  // the implied zero
}
