// The envelope by hand (envelope.hpp). The reader follows libprotobuf 3.21's parser rule for rule, as
// its generated code for tether_rpc.proto runs it: tags of at most 5 bytes, varints of at most 10 (the
// value's low bits kept), lengths of at most 5 bytes and under 2 GiB, every field inside its message,
// a known field number with another wire type taken as an unknown field, unknown groups skipped up to
// their own end-group tag, messages and groups nested at most 100 deep.
#include "tether/rpc/envelope.hpp"

#include <google/protobuf/stubs/common.h>

#include <algorithm>
#include <array>
#include <vector>

#include "tether/core/crc.hpp"
#include "tether/core/utf8.hpp"
#include "tether/proxy/cobs.hpp"
#include "tether/proxy/encoder.hpp"

namespace tether::rpc::envelope {
namespace {

// --- writing ---------------------------------------------------------------------------------------------

constexpr std::uint8_t kVarint = 0;
constexpr std::uint8_t kFixed64 = 1;
constexpr std::uint8_t kLengthDelimited = 2;
constexpr std::uint8_t kStartGroup = 3;
constexpr std::uint8_t kEndGroup = 4;
constexpr std::uint8_t kFixed32 = 5;

constexpr std::uint8_t tag(std::uint8_t field, std::uint8_t wire_type) {
  return static_cast<std::uint8_t>(field << 3 | wire_type);
}

std::size_t varint_size(std::uint64_t value) {
  std::size_t size = 1;
  while (value >= 0x80) {
    value >>= 7;
    ++size;
  }
  return size;
}

std::uint8_t* put_varint(std::uint8_t* out, std::uint64_t value) {
  while (value >= 0x80) {
    *out++ = static_cast<std::uint8_t>(value | 0x80);
    value >>= 7;
  }
  *out++ = static_cast<std::uint8_t>(value);
  return out;
}

// A proto3 scalar: written only when not zero (tags here are one byte: field numbers below 16).
std::size_t scalar_size(std::uint32_t value) { return value == 0 ? 0 : 1 + varint_size(value); }
std::uint8_t* put_scalar(std::uint8_t* out, std::uint8_t field, std::uint32_t value) {
  if (value == 0) return out;
  *out++ = tag(field, kVarint);
  return put_varint(out, value);
}
std::size_t bytes_size(ByteView bytes) { return bytes.empty() ? 0 : 1 + varint_size(bytes.size()) + bytes.size(); }
std::uint8_t* put_bytes(std::uint8_t* out, std::uint8_t field, ByteView bytes) {
  if (bytes.empty()) return out;
  *out++ = tag(field, kLengthDelimited);
  out = put_varint(out, bytes.size());
  for (const std::uint8_t byte : bytes) *out++ = byte;
  return out;
}

// The body's message (Call, OpenStream, ...), without its tag and length.
std::size_t body_size(const HostMessage& message) {
  switch (message.body) {
    case HostBody::call:
      return scalar_size(message.method) + bytes_size(message.request);
    case HostBody::open:
      return scalar_size(message.method) + bytes_size(message.request) + scalar_size(message.period_ms);
    case HostBody::close:
      return scalar_size(message.stream);
    case HostBody::none:
    case HostBody::hello:
    case HostBody::ping:
    case HostBody::reset:
      break;
  }
  return 0;
}

// --- reading ---------------------------------------------------------------------------------------------

// libprotobuf's recursion limit (io::CodedInputStream's default): the body's message is one level, each
// group another.
constexpr int kMaxDepth = 100;

struct Cursor {
  const std::uint8_t* at;
  const std::uint8_t* end;
  std::size_t left() const { return static_cast<std::size_t>(end - at); }
};

// A varint of at most 10 bytes; the bits past 64 are dropped (a 32-bit field keeps the low 32).
DecodeError read_varint(Cursor& in, std::uint64_t& value) {
  if (in.at != in.end && *in.at < 0x80) {  // one byte: most values
    value = *in.at++;
    return DecodeError::none;
  }
  std::uint64_t result = 0;
  for (unsigned i = 0; i < 10; ++i) {
    if (in.at == in.end) return DecodeError::truncated;
    const std::uint8_t byte = *in.at++;
    result |= static_cast<std::uint64_t>(byte & 0x7F) << (7 * i);
    if (byte < 0x80) {
      value = result;
      return DecodeError::none;
    }
  }
  return DecodeError::bad_varint;
}

// A tag: at most 5 bytes, the bits past 32 dropped.
DecodeError read_tag(Cursor& in, std::uint32_t& value) {
  if (in.at != in.end && *in.at < 0x80) {  // one byte: field numbers below 16
    value = *in.at++;
    return DecodeError::none;
  }
  std::uint32_t result = 0;
  for (unsigned i = 0; i < 5; ++i) {
    if (in.at == in.end) return DecodeError::truncated;
    const std::uint8_t byte = *in.at++;
    result |= static_cast<std::uint32_t>(byte & 0x7F) << (7 * i);
    if (byte < 0x80) {
      value = result;
      return DecodeError::none;
    }
  }
  return DecodeError::bad_varint;
}

// A length: at most 5 bytes and below 2 GiB, then that many bytes inside the message.
DecodeError read_length(Cursor& in, ByteView& bytes) {
  std::uint32_t size = 0;
  if (in.at != in.end && *in.at < 0x80) {  // one byte: below 128
    size = *in.at++;
  } else {
    for (unsigned i = 0;; ++i) {
      if (in.at == in.end) return DecodeError::truncated;
      const std::uint8_t byte = *in.at++;
      if (i == 4 && byte >= 0x08) return DecodeError::bad_length;
      size |= static_cast<std::uint32_t>(byte & 0x7F) << (7 * i);
      if (byte < 0x80) break;
    }
  }
  if (size > in.left()) return DecodeError::truncated;
  bytes = ByteView(in.at, size);
  in.at += size;
  return DecodeError::none;
}

DecodeError skip(Cursor& in, std::size_t count) {
  if (count > in.left()) return DecodeError::truncated;
  in.at += count;
  return DecodeError::none;
}

DecodeError skip_group(Cursor& in, std::uint32_t start_tag, int depth);

// An unknown field (or a known one with another wire type) after its tag: skipped. End-group tags are
// the caller's.
DecodeError skip_field(Cursor& in, std::uint32_t field_tag, int depth) {
  if ((field_tag >> 3) == 0) return DecodeError::bad_tag;
  switch (field_tag & 7) {
    case kVarint: {
      std::uint64_t ignored = 0;
      return read_varint(in, ignored);
    }
    case kFixed64:
      return skip(in, 8);
    case kLengthDelimited: {
      ByteView ignored;
      return read_length(in, ignored);
    }
    case kStartGroup:
      return skip_group(in, field_tag, depth);
    case kFixed32:
      return skip(in, 4);
    default:
      return DecodeError::bad_tag;
  }
}

// The fields of a group up to its end-group tag (the start tag's field number, wire type 4).
DecodeError skip_group(Cursor& in, std::uint32_t start_tag, int depth) {
  if (--depth < 0) return DecodeError::too_deep;
  while (in.at != in.end) {
    std::uint32_t field_tag = 0;
    if (const DecodeError error = read_tag(in, field_tag); error != DecodeError::none) return error;
    if (field_tag == 0) return DecodeError::bad_tag;
    if ((field_tag & 7) == kEndGroup) {
      return field_tag == start_tag + 1 ? DecodeError::none : DecodeError::unexpected_end_group;
    }
    if (const DecodeError error = skip_field(in, field_tag, depth); error != DecodeError::none) return error;
  }
  return DecodeError::unterminated_group;
}

// Reads the fields of one message, handing each known (field, wire type) to `known`, which reads its value
// and returns an error, or `skip_field`'s sentinel to have it skipped as unknown.
constexpr DecodeError kUnknown = static_cast<DecodeError>(0xFF);

template <typename Known>
DecodeError read_fields(Cursor in, int depth, Known&& known) {
  while (in.at != in.end) {
    std::uint32_t field_tag = 0;
    if (const DecodeError error = read_tag(in, field_tag); error != DecodeError::none) return error;
    if (field_tag == 0) return DecodeError::bad_tag;
    if ((field_tag & 7) == kEndGroup) return DecodeError::unexpected_end_group;
    DecodeError error = (field_tag >> 3) < 16 ? known(static_cast<std::uint8_t>(field_tag), in) : kUnknown;
    if (error == kUnknown) error = skip_field(in, field_tag, depth);
    if (error != DecodeError::none) return error;
  }
  return DecodeError::none;
}

DecodeError read_u32(Cursor& in, std::uint32_t& value) {
  std::uint64_t wide = 0;
  const DecodeError error = read_varint(in, wide);
  value = static_cast<std::uint32_t>(wide);
  return error;
}

DecodeError read_fixed64(Cursor& in, std::uint64_t& value) {
  if (in.left() < 8) return DecodeError::truncated;
  std::uint64_t result = 0;
  for (unsigned i = 0; i < 8; ++i) result |= static_cast<std::uint64_t>(in.at[i]) << (8 * i);
  in.at += 8;
  value = result;
  return DecodeError::none;
}

// The body's message, merged into `out`'s member (libprotobuf's merge of a repeated message field).
DecodeError read_body(std::uint8_t field, ByteView bytes, int depth, DeviceMessage& out) {
  Cursor in{bytes.data(), bytes.data() + bytes.size()};
  switch (static_cast<DeviceBody>(field)) {
    case DeviceBody::ack:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kVarint)) return read_u32(c, out.ack.id);
        if (t == tag(2, kVarint)) {
          std::uint64_t value = 0;
          const DecodeError error = read_varint(c, value);
          out.ack.refused = value != 0;
          return error;
        }
        return kUnknown;
      });
    case DeviceBody::reply:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kVarint)) return read_u32(c, out.reply.call);
        if (t == tag(2, kLengthDelimited)) return read_length(c, out.reply.reply);
        return kUnknown;
      });
    case DeviceBody::error:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kVarint)) return read_u32(c, out.error.call);
        if (t == tag(2, kVarint)) return read_u32(c, out.error.code);
        if (t == tag(3, kLengthDelimited)) return read_length(c, out.error.text);
        return kUnknown;
      });
    case DeviceBody::stream:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kVarint)) return read_u32(c, out.stream.stream);
        if (t == tag(2, kVarint)) return read_u32(c, out.stream.seq);
        if (t == tag(3, kLengthDelimited)) return read_length(c, out.stream.message);
        return kUnknown;
      });
    case DeviceBody::hello:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kFixed64)) return read_fixed64(c, out.hello.schema_hash);
        if (t == tag(2, kVarint)) return read_u32(c, out.hello.session);
        if (t == tag(3, kVarint)) return read_u32(c, out.hello.max_payload);
        if (t == tag(4, kVarint)) return read_u32(c, out.hello.methods);
        return kUnknown;
      });
    case DeviceBody::reset:
      return read_fields(in, depth, [&](std::uint8_t t, Cursor& c) {
        if (t == tag(1, kVarint)) return read_u32(c, out.reset.session);
        return kUnknown;
      });
    case DeviceBody::none:
      break;
  }
  return DecodeError::none;
}

// --- framing ---------------------------------------------------------------------------------------------

constexpr std::size_t kSmallFrame = 160;

// CRC-16/MCRF4XX of `size` bytes with the core's slicing tables (core/crc.hpp, the same as
// Crc16Mcrf4xx::compute): eight bytes per step, then the last 0..7 in one step of their own (Crc16Mcrf4xx
// takes those one by one, a chain of dependent loads). For n >= 2 bytes the register is absorbed by the
// first two and byte i's share is row n-1-i.
std::uint16_t crc16(const std::uint8_t* in, std::size_t size) {
  using Slices = tether::detail::CrcSlices<boost::crc_optimal<16, 0x1021, 0x0000, 0x0000, true, true>, std::uint16_t>;
  const Slices& t = Slices::get();
  unsigned crc = 0xFFFF;
  for (; size >= 8; size -= 8, in += 8) {
    crc = t.row[7][(crc ^ in[0]) & 0xFFu] ^ t.row[6][((crc >> 8) ^ in[1]) & 0xFFu] ^ t.row[5][in[2]] ^ t.row[4][in[3]] ^
          t.row[3][in[4]] ^ t.row[2][in[5]] ^ t.row[1][in[6]] ^ t.row[0][in[7]];
  }
  if (size == 1) return static_cast<std::uint16_t>((crc >> 8) ^ t.row[0][(crc ^ in[0]) & 0xFFu]);
  if (size == 0) return static_cast<std::uint16_t>(crc);
  unsigned tail = t.row[size - 1][(crc ^ in[0]) & 0xFFu] ^ t.row[size - 2][((crc >> 8) ^ in[1]) & 0xFFu];
  for (std::size_t i = 2; i < size; ++i) tail ^= t.row[size - 1 - i][in[i]];
  return static_cast<std::uint16_t>(tail);
}

// 0x00, COBS(raw), 0x00 at `out` (room for proxy::max_frame_size(size - 2)); the frame's size. Block by
// block (a block: up to 254 non-zero bytes, then a zero or the end) with its code written once, the same
// bytes as proxy::detail::CobsWriter's byte steps (a full block is followed by a new one, empty at the end).
std::size_t cobs_frame(const std::uint8_t* raw, std::size_t size, std::uint8_t* const out) {
  out[0] = 0x00;
  std::uint8_t* at = out + 1;
  const std::uint8_t* in = raw;
  const std::uint8_t* const end = raw + size;
  for (;;) {
    std::uint8_t* const code = at++;
    const std::uint8_t* const block_end = in + std::min<std::size_t>(254, static_cast<std::size_t>(end - in));
    const std::uint8_t* scan = in;
    while (scan != block_end && *scan != 0x00) *at++ = *scan++;
    const auto length = static_cast<std::size_t>(scan - in);
    *code = static_cast<std::uint8_t>(length + 1);
    if (scan == block_end) {
      if (length < 254) break;  // the data's end
      in = scan;                // a full block: no zero follows it
      continue;
    }
    in = scan + 1;  // past the zero the block stands for
  }
  *at++ = 0x00;
  return static_cast<std::size_t>(at - out);
}

// A frame whose request is longer than the client sends (tests, other programs): on the heap.
__attribute__((noinline)) void write_large_frame(const HostMessage& message, std::size_t size, std::string& frame) {
  std::vector<std::uint8_t> raw(size + 2);
  (void)encode(message, raw.data() + 2);
  const std::uint16_t crc = crc16(raw.data() + 2, size);
  raw[0] = static_cast<std::uint8_t>(crc & 0xFF);
  raw[1] = static_cast<std::uint8_t>(crc >> 8);
  std::vector<std::uint8_t> out(proxy::max_frame_size(size));
  frame.assign(reinterpret_cast<const char*>(out.data()), cobs_frame(raw.data(), raw.size(), out.data()));
}

}  // namespace

std::size_t encoded_size(const HostMessage& message) {
  std::size_t size = scalar_size(message.id);
  if (message.body != HostBody::none) {
    const std::size_t body = body_size(message);
    size += 1 + varint_size(body) + body;
  }
  return size;
}

std::size_t encode(const HostMessage& message, std::uint8_t* const out) {
  std::uint8_t* at = put_scalar(out, 1, message.id);
  if (message.body != HostBody::none) {
    *at++ = tag(static_cast<std::uint8_t>(message.body), kLengthDelimited);
    at = put_varint(at, body_size(message));
    switch (message.body) {
      case HostBody::call:
      case HostBody::open:
        at = put_scalar(at, 1, message.method);
        at = put_bytes(at, 2, message.request);
        if (message.body == HostBody::open) at = put_scalar(at, 3, message.period_ms);
        break;
      case HostBody::close:
        at = put_scalar(at, 1, message.stream);
        break;
      case HostBody::none:
      case HostBody::hello:
      case HostBody::ping:
      case HostBody::reset:
        break;
    }
  }
  return static_cast<std::size_t>(at - out);
}

void write_frame(const HostMessage& message, std::string& frame) {
  // The frame's raw bytes (crc16 ‖ payload) on the stack (the client's requests are at most 64 bytes); the
  // CRC first, eight bytes per table step and the rest in one more, then COBS in one byte loop: two short
  // passes beat one whose every byte also feeds the CRC (proxy::encode_frame's loop, written for the
  // AVR). The same bytes as proxy::encode_frame with a leading delimiter.
  const std::size_t size = encoded_size(message);
  if (size + 2 > kSmallFrame) {
    write_large_frame(message, size, frame);
    return;
  }
  std::array<std::uint8_t, kSmallFrame> raw;
  (void)encode(message, raw.data() + 2);
  const std::uint16_t crc = crc16(raw.data() + 2, size);
  raw[0] = static_cast<std::uint8_t>(crc & 0xFF);
  raw[1] = static_cast<std::uint8_t>(crc >> 8);
  std::array<std::uint8_t, proxy::max_frame_size(kSmallFrame)> out;
  const std::size_t written = cobs_frame(raw.data(), size + 2, out.data());
  frame.assign(reinterpret_cast<const char*>(out.data()), written);
}

const char* describe(DecodeError error) {
  switch (error) {
    case DecodeError::none: return "no error";
    case DecodeError::truncated: return "a field runs past the end of its message";
    case DecodeError::bad_varint: return "a varint is longer than 10 bytes (a tag or a length longer than 5)";
    case DecodeError::bad_tag: return "a field number 0 or a wire type 6 or 7";
    case DecodeError::bad_length: return "a length of 2 GiB or more";
    case DecodeError::unexpected_end_group: return "an end-group tag outside its group";
    case DecodeError::unterminated_group: return "a group without its end-group tag";
    case DecodeError::too_deep: return "messages and groups nested more than 100 deep";
  }
  return "unknown envelope error";
}

DecodeError decode(ByteView payload, DeviceMessage& out) {
  out = DeviceMessage();
  Cursor in{payload.data(), payload.data() + payload.size()};
  return read_fields(in, kMaxDepth, [&](std::uint8_t t, Cursor& c) {
    const std::uint8_t field = static_cast<std::uint8_t>(t >> 3);
    if ((t & 7) != kLengthDelimited || field < 1 || field > 6) return kUnknown;
    ByteView bytes;
    if (const DecodeError error = read_length(c, bytes); error != DecodeError::none) return error;
    const auto body = static_cast<DeviceBody>(field);
    if (out.body != body) {  // another member of the oneof: it replaces the one before
      if (out.body != DeviceBody::none) out = DeviceMessage();  // none: still the fresh one
      out.body = body;
    }
    return read_body(field, bytes, kMaxDepth - 1, out);
  });
}

WholeFrame read_whole_frame(ByteView encoded, std::uint8_t* const out, std::size_t capacity, std::size_t& size) {
  // The decoder's steps, a block at a time: each code byte after the first stores the zero its previous
  // block (one of fewer than 254 bytes) stood for, then the block's bytes; a store past `capacity` is
  // the decoder's overflow, which comes before a block cut short (found only at the delimiter).
  const std::uint8_t* in = encoded.data();
  const std::uint8_t* const end = in + encoded.size();
  std::size_t at = 0;
  std::uint8_t last_code = 0xFF;  // the first code stores no zero
  while (in != end) {
    const std::uint8_t code = *in++;
    if (last_code != 0xFF) {
      if (at == capacity) return WholeFrame::too_long;
      out[at++] = 0x00;
    }
    last_code = code;
    const std::size_t block = code - 1u;
    const auto left = static_cast<std::size_t>(end - in);
    const std::size_t here = block < left ? block : left;
    if (here > capacity - at) return WholeFrame::too_long;
    std::memcpy(out + at, in, here);
    at += here;
    in += here;
    if (here != block) return WholeFrame::bad_cobs;
  }
  if (at < 2) return WholeFrame::too_short;
  const auto sent = static_cast<std::uint16_t>(out[0] | out[1] << 8);
  if (crc16(out + 2, at - 2) != sent) return WholeFrame::crc_mismatch;
  size = at;
  return WholeFrame::frame;
}

bool text_is_utf8(ByteView text) {
  return google::protobuf::internal::IsStructurallyValidUTF8(reinterpret_cast<const char*>(text.data()),
                                                             static_cast<int>(text.size()));
}

std::string device_text(ByteView text) {
  if (text_is_utf8(text)) return std::string(reinterpret_cast<const char*>(text.data()), text.size());
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string escaped;
  escaped.reserve(text.size() + 8);
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t length = utf8_sequence_length(text.data(), text.size(), i);
    if (length != 0) {
      escaped.append(reinterpret_cast<const char*>(text.data()) + i, length);
      i += length;
      continue;
    }
    const std::uint8_t byte = text[i++];
    escaped += "\\x";
    escaped += kDigits[byte >> 4];
    escaped += kDigits[byte & 0x0F];
  }
  return escaped;
}

}  // namespace tether::rpc::envelope
