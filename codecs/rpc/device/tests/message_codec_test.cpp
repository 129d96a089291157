// The device's message codec (message_codec.hpp) against nanopb 0.4 on the same structs (codec.proto:
// every field kind): randomized protobuf-like inputs (seeded, RANDOM_SEED replays a run) decoded both ways
// with the same outcome and struct, re-encoded to the same bytes (with room, and without), and the
// encoder's refusals (over-bound counts, unterminated strings, oversized bytes) as nanopb's.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>

#include "codec_check.hpp"
#include "tether/testing/random_seed.hpp"

namespace {

using codec_check::compare_all;
using codec_check::compare_encode;

void put_varint(std::string& out, std::uint64_t value) {
  while (value >= 0x80) {
    out += static_cast<char>(static_cast<std::uint8_t>(value | 0x80));
    value >>= 7;
  }
  out += static_cast<char>(static_cast<std::uint8_t>(value));
}

std::uint64_t random_number(std::mt19937_64& rng) {
  static const std::uint64_t kEdges[] = {0,           1,          127,        128,        255,       256,
                                         32767,       32768,      65535,      65536,      0x7FFFFFFF, 0x80000000,
                                         0xFFFFFFFF,  0x100000000, ~0ull,     ~0ull - 1,  0xFFFFFFFF80000000ull,
                                         0xFFFFFFFFFFFFFF80ull};
  switch (rng() % 5) {
    case 0: return rng() % 300;
    case 1: return kEdges[rng() % (sizeof kEdges / sizeof kEdges[0])];
    case 2: return static_cast<std::uint64_t>(-static_cast<std::int64_t>(rng() % 100000));  // a negative int
    case 3: return rng() & 0xFFFFFFFF;
    default: return rng();
  }
}

// A protobuf-like message: fields of the schema's numbers (and others), mostly of a fitting wire type,
// values at the edges of every integer type, nested messages, packed runs and text.
// `numbers`: the field numbers mostly drawn (1..numbers).
std::string random_message(std::mt19937_64& rng, int depth, std::uint32_t numbers = 38) {
  std::string out;
  const int fields = static_cast<int>(rng() % 9);
  for (int f = 0; f < fields; ++f) {
    const auto number = static_cast<std::uint32_t>(rng() % 16 == 0 ? rng() % 3000 : 1 + rng() % numbers);
    const auto pick = static_cast<unsigned>(rng() % 100);
    const std::uint8_t wire = pick < 40 ? 2 : pick < 75 ? 0 : pick < 85 ? 5 : pick < 95 ? 1 : static_cast<std::uint8_t>(3 + rng() % 5);
    put_varint(out, static_cast<std::uint64_t>(number) << 3 | wire);
    switch (wire) {
      case 0: {
        put_varint(out, random_number(rng));
        if (rng() % 20 == 0) {  // an over-long encoding: a continuation and a zero byte more
          out.back() = static_cast<char>(static_cast<std::uint8_t>(out.back()) | 0x80);
          out += '\0';
        }
        break;
      }
      case 1:
      case 5:
        for (int i = 0; i < (wire == 1 ? 8 : 4); ++i) out += static_cast<char>(rng());
        break;
      case 2: {
        std::string content;
        const auto kind = static_cast<unsigned>(rng() % 10);
        if (kind < 4 && depth < 3) {
          content = random_message(rng, depth + 1, numbers);
        } else if (kind < 7) {
          const int values = static_cast<int>(rng() % 6);
          for (int i = 0; i < values; ++i) put_varint(content, random_number(rng));
        } else {
          const int length = static_cast<int>(rng() % 14);
          for (int i = 0; i < length; ++i) content += static_cast<char>(rng() % 4 == 0 ? rng() : 'a' + rng() % 26);
        }
        put_varint(out, content.size() + (rng() % 30 == 0 ? 1 : 0));  // now and then a length past the end
        out += content;
        break;
      }
      default:
        break;
    }
  }
  switch (rng() % 20) {
    case 0:
      if (!out.empty()) out[rng() % out.size()] = static_cast<char>(rng());
      break;
    case 1:
      if (!out.empty()) out.resize(rng() % out.size());
      break;
    case 2:
      out += static_cast<char>(rng());
      break;
    default:
      break;
  }
  return out;
}

TEST(RpcMessageCodec, RandomInputsDecodeAndEncodeAsNanopb) {
  std::mt19937_64 rng = tether::testing::seeded_generator();
  int accepted = 0;
  for (int i = 0; i < 30000; ++i) {
    const std::string input = random_message(rng, 0);
    const auto* data = reinterpret_cast<const std::uint8_t*>(input.data());
    const std::size_t short_capacity = static_cast<std::size_t>(rng() % 80);
    const codec_check::Difference d = compare_all(data, input.size(), short_capacity);
    ASSERT_FALSE(d) << d.what << " on input " << i << " (" << input.size() << " bytes)";
    pb_istream_t stream = pb_istream_from_buffer(data, input.size());
    codec_All all = codec_All_init_zero;
    if (pb_decode(&stream, codec_All_fields, &all)) ++accepted;
  }
  std::printf("%d of 30000 random inputs were All messages nanopb accepts\n", accepted);
}

// The envelope's hand-written decoder (envelope.hpp) on HostMessage-like inputs (its field numbers and its
// bodies'), as nanopb decodes them.
TEST(RpcMessageCodec, RandomEnvelopesDecodeAsNanopb) {
  std::mt19937_64 rng = tether::testing::seeded_generator();
  int accepted = 0;
  for (int i = 0; i < 30000; ++i) {
    const std::string input = random_message(rng, 0, 8);
    const auto* data = reinterpret_cast<const std::uint8_t*>(input.data());
    const codec_check::Difference d = codec_check::compare_envelope(data, input.size());
    ASSERT_FALSE(d) << d.what << " on input " << i << " (" << input.size() << " bytes)";
    pb_istream_t stream = pb_istream_from_buffer(data, input.size());
    tether_rpc_wire_HostMessage message = tether_rpc_wire_HostMessage_init_zero;
    if (pb_decode(&stream, tether_rpc_wire_HostMessage_fields, &message)) ++accepted;
  }
  std::printf("%d of 30000 random inputs were HostMessages nanopb accepts\n", accepted);
  EXPECT_GT(accepted, 3000);  // the comparison saw many accepted ones, not only refusals
}

// A Call's or OpenStream's request at its bound (64 bytes) is accepted, one byte more refused, as by nanopb.
TEST(RpcMessageCodec, EnvelopeRequestsOverTheirBoundAreRefusedAsByNanopb) {
  for (const std::uint32_t body : {3u, 4u}) {  // HostMessage.call, HostMessage.open
    for (const std::size_t length : {std::size_t{63}, std::size_t{64}, std::size_t{65}}) {
      std::string inner;
      put_varint(inner, 2 << 3 | 2);  // request
      put_varint(inner, length);
      inner.append(length, 'r');
      std::string input;
      put_varint(input, 1 << 3);  // id 9
      put_varint(input, 9);
      put_varint(input, body << 3 | 2);
      put_varint(input, inner.size());
      input += inner;
      const auto* data = reinterpret_cast<const std::uint8_t*>(input.data());
      const codec_check::Difference d = codec_check::compare_envelope(data, input.size());
      EXPECT_FALSE(d) << d.what << " (body " << body << ", " << length << " bytes)";
      tether_rpc_wire_HostMessage message;
      EXPECT_EQ(tether::rpc::device::decode_host_message(data, input.size(), message), length <= 64);
    }
  }
}

TEST(RpcMessageCodec, AMessageWithEveryFieldSetEncodesAsNanopb) {
  codec_All all = codec_All_init_zero;
  all.i32 = -5;
  all.i64 = -1234567890123;
  all.u32 = 0xFFFFFFFF;
  all.u64 = ~0ull;
  all.s32 = -2147483647 - 1;
  all.s64 = -3;
  all.b = true;
  all.f32 = 7;
  all.f64 = 8;
  all.sf32 = -9;
  all.sf64 = -10;
  all.fl = -0.0f;  // nanopb: not all bytes zero, so written
  all.db = 1.5;
  std::strcpy(all.str, "eleven char");
  all.byt.size = 7;
  all.color = codec_Color_BLUE;
  all.sig = codec_Signed_MINUS;
  all.has_inner = true;
  all.inner.a = -1;
  all.ri32_count = 4;
  all.ri32[3] = -7;
  all.rstr_count = 2;
  std::strcpy(all.rstr[1], "five5");
  all.rbyt_count = 1;
  all.rinner_count = 2;
  all.rinner[1].r_count = 3;
  all.rinner[1].r[2] = -100;
  all.rb_count = 3;
  all.rb[1] = true;
  all.rsig_count = 2;
  all.rsig[0] = codec_Signed_MINUS;
  all.which_choice = codec_All_cinner_tag;
  all.has_opt = true;  // zero, but present
  all.ru64_count = 1;
  all.small = -128;
  all.usmall = 65535;
  all.fixed[0] = 1;
  all.has_deep = true;
  all.deep.items_count = 1;
  all.rfl_count = 1;
  all.rs64_count = 2;
  all.rs64[1] = -1;
  for (std::size_t capacity : {std::size_t{1024}, std::size_t{0}, std::size_t{10}, std::size_t{100}, std::size_t{180}}) {
    const codec_check::Difference d =
        compare_encode(codec_All_fields, &tether_rpc_encode_codec_All, all, capacity);
    EXPECT_FALSE(d) << d.what;
  }
}

TEST(RpcMessageCodec, FieldsOverTheirBoundsAreRefusedAsByNanopb) {
  const auto refused_both_ways = [](const codec_All& all) {
    EXPECT_FALSE(compare_encode(codec_All_fields, &tether_rpc_encode_codec_All, all, 1024));
    std::uint8_t out[1024];
    tether::rpc::device::wire::Writer writer(out, sizeof out);
    return !tether_rpc_encode_codec_All(writer, &all);
  };
  codec_All all = codec_All_init_zero;
  all.ri32_count = 5;  // max_count 4
  EXPECT_TRUE(refused_both_ways(all));
  all = codec_All_init_zero;
  std::memset(all.str, 'x', sizeof all.str);  // no NUL within max_size
  EXPECT_TRUE(refused_both_ways(all));
  all = codec_All_init_zero;
  all.byt.size = 9;  // max_size 7 (nanopb's bound is the struct's room: 8 on a host, where it is padded)
  EXPECT_TRUE(refused_both_ways(all));
  all = codec_All_init_zero;
  all.has_inner = true;
  all.inner.r_count = 4;  // in a submessage
  EXPECT_TRUE(refused_both_ways(all));

  // Decoding: a string, bytes or repeated field longer than its bound is refused, never truncated.
  codec_All out;
  const std::uint8_t long_string[] = {14 << 3 | 2, 12, 'a', 'b', 'c', 'd', 'e', 'f', 'g', 'h', 'i', 'j', 'k', 'l'};
  EXPECT_FALSE(tether_rpc_decode_codec_All(long_string, sizeof long_string, &out));
  EXPECT_FALSE(compare_all(long_string, sizeof long_string, 0));
  const std::uint8_t packed_over[] = {0x9A, 0x01, 5, 1, 2, 3, 4, 5};  // field 19 packed, max_count 4
  EXPECT_FALSE(tether_rpc_decode_codec_All(packed_over, sizeof packed_over, &out));
  const std::uint8_t small_over[] = {0x80, 0x02, 0x80, 0x01};  // field 32: 128 in an int8_t field
  EXPECT_FALSE(tether_rpc_decode_codec_All(small_over, sizeof small_over, &out));
  const std::uint8_t fits[] = {0x9A, 0x01, 4, 1, 2, 3, 4, 0x98, 0x01, 5};  // a fifth one unpacked
  EXPECT_FALSE(tether_rpc_decode_codec_All(fits, sizeof fits, &out));
  EXPECT_TRUE(tether_rpc_decode_codec_All(fits, 7, &out));
  EXPECT_EQ(out.ri32_count, 4);
  EXPECT_EQ(out.ri32[3], 4);
}

TEST(RpcMessageCodec, ANegativeInt32IsItsTenByteSignExtension) {
  codec_Inner inner = codec_Inner_init_zero;
  inner.a = -2;
  std::uint8_t out[16];
  tether::rpc::device::wire::Writer writer(out, sizeof out);
  ASSERT_TRUE(tether_rpc_encode_codec_Inner(writer, &inner));
  const std::uint8_t expected[] = {0x08, 0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01};
  ASSERT_EQ(writer.size(), sizeof expected);
  EXPECT_EQ(std::memcmp(out, expected, sizeof expected), 0);
  tether::rpc::device::wire::Writer short_writer(out, 10);  // one byte short
  EXPECT_FALSE(tether_rpc_encode_codec_Inner(short_writer, &inner));
}

}  // namespace
