#include "tether/romi/encoder.hpp"

#include "tether/core/crc.hpp"
#include "tether/romi/request_parser.hpp"

namespace tether {
namespace romi {
namespace {

// Sequential writer into a caller's buffer; remembers overflow instead of failing at each step.
class FrameWriter {
 public:
  explicit FrameWriter(MutableByteView out) : out_(out) {}
  void put(uint8_t c) {
    if (size_ < out_.size()) out_[size_] = c;
    ++size_;
  }
  void put(ByteView bytes) {
    for (uint8_t c : bytes) put(c);
  }
  void put_manual_metadata() { put(ByteView::from_literal(":xxxx\r\n")); }
  Result<size_t> result() const {
    if (size_ > out_.size()) return Status::buffer_too_small;
    return size_;
  }

 private:
  MutableByteView out_;
  size_t size_ = 0;
};

bool is_reserved(uint8_t c) { return c == '#' || c == ':' || c == '"' || c == '\r' || c == '\n'; }

}  // namespace

bool is_string_char(uint8_t c) {
  if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')) return true;
  switch (c) {
    case '-': case '_': case ' ': case '!': case '?': case '%': case '(': case ')': case '[': case ']':
    case '{': case '}': case '&': case '=': case '+': case '*': case '/': case '.': case ',': case ';':
    case '\'':
      return true;
    default:
      return false;
  }
}

Result<size_t> encode_request(ByteView payload, uint8_t id, MutableByteView out) {
  // The size is known up front: one check, a copy, and the CRC over the written run (the host's hot
  // path: a bounds check and a CRC step per byte cost more than the rest of the frame).
  const size_t size = payload.size() + kFrameOverhead;
  if (size > out.size()) return Status::buffer_too_small;
  uint8_t* next = out.data();
  *next++ = '#';
  for (const uint8_t c : payload) *next++ = c;
  *next++ = ':';
  *next++ = hex_digit(high_nibble(id));
  *next++ = hex_digit(static_cast<uint8_t>(id & 0xF));
  const uint8_t crc = Crc8Smbus::compute(ByteView(out.data(), static_cast<size_t>(next - out.data())));
  *next++ = hex_digit(high_nibble(crc));
  *next++ = hex_digit(static_cast<uint8_t>(crc & 0xF));
  *next++ = '\r';
  *next = '\n';
  return size;
}

Result<size_t> encode_manual_request(ByteView payload, MutableByteView out) {
  FrameWriter writer(out);
  writer.put('#');
  writer.put(payload);
  writer.put_manual_metadata();
  return writer.result();
}

Result<size_t> encode_response(char opcode, ByteView body, uint8_t id, MutableByteView out) {
  // One straight pass, no per-byte calls or bounds checks: the size is known up front.
  if (body.size() + kResponseOverhead > out.size()) return Status::buffer_too_small;
  return form_response(opcode, body.data(), body.size(), id, out.data());
}

Result<size_t> encode_log(ByteView text, MutableByteView out) {
  FrameWriter writer(out);
  writer.put('#');
  writer.put('!');
  for (uint8_t c : text) writer.put(c == '\r' || c == '\n' ? static_cast<uint8_t>(' ') : c);
  writer.put_manual_metadata();
  return writer.result();
}

RequestBuilder::RequestBuilder(char opcode) {
  if (!is_opcode(static_cast<uint8_t>(opcode))) {
    error_ = Error::invalid_opcode;
    return;
  }
  append(static_cast<uint8_t>(opcode));
}

void RequestBuilder::append(uint8_t c) {
  if (size_ >= kMaxHostPayload) {
    if (error_ == Error::no_error) error_ = Error::client_request_too_long;
    return;
  }
  buffer_[size_++] = c;
}

void RequestBuilder::open_argument() {
  if (arguments_ == 0 && !has_string_) {
    append('[');
  } else {
    --size_;  // the closing ']' becomes a separator
    append(',');
  }
}

RequestBuilder& RequestBuilder::add_int(int32_t value) {
  if (error_ != Error::no_error) return *this;
  if (arguments_ == kMaxArguments) {
    error_ = Error::too_many_arguments;
    return *this;
  }
  if (value < -32768 || value > 32767) {
    error_ = Error::value_out_of_range;
    return *this;
  }
  // The argument's text (separator, sign, digits, ']') is written in place, its length known first: one
  // length check instead of a checked append per character (the host's per-frame cost).
  const uint32_t magnitude = value < 0 ? static_cast<uint32_t>(-value) : static_cast<uint32_t>(value);
  const size_t digits = 1u + (magnitude >= 10u) + (magnitude >= 100u) + (magnitude >= 1000u) + (magnitude >= 10000u);
  const bool opens = arguments_ == 0 && !has_string_;
  const size_t start = opens ? size_ : size_ - 1;  // the separator replaces the closing ']' so far
  const size_t end = start + 1u + (value < 0 ? 1u : 0u) + digits + 1u;
  if (end > kMaxHostPayload) {
    error_ = Error::client_request_too_long;
    return *this;
  }
  buffer_[start] = opens ? '[' : ',';
  if (value < 0) buffer_[start + 1] = '-';
  uint8_t* digit = buffer_ + end - 1;
  *digit = ']';
  uint32_t rest = magnitude;
  do {
    *--digit = static_cast<uint8_t>('0' + rest % 10u);
    rest /= 10u;
  } while (rest != 0);
  size_ = end;
  ++arguments_;
  return *this;
}

RequestBuilder& RequestBuilder::add_string(ByteView text) {
  if (error_ != Error::no_error) return *this;
  if (has_string_) {
    error_ = Error::too_many_strings;
    return *this;
  }
  if (text.size() > kMaxStringLength) {
    error_ = Error::string_too_long;
    return *this;
  }
  for (uint8_t c : text) {
    if (is_reserved(c)) {
      error_ = Error::reserved_character;
      return *this;
    }
    if (!is_string_char(c)) {
      error_ = Error::invalid_string;
      return *this;
    }
  }
  open_argument();
  append('"');
  for (uint8_t c : text) append(c);
  append('"');
  append(']');
  has_string_ = true;
  return *this;
}

Error validate_request_payload(ByteView payload) {
  size_t error_offset = 0;
  return validate_request_payload(payload, error_offset);
}

Error validate_request_payload(ByteView payload, size_t& error_offset) {
  error_offset = payload.size();
  if (payload.empty()) return Error::client_empty_request;
  for (size_t i = 0; i < payload.size(); ++i) {
    const uint8_t c = payload[i];
    if (c == '#' || c == ':' || c == '\r' || c == '\n') {
      error_offset = i;
      return Error::reserved_character;
    }
  }
  ParsedRequest request;
  const Error parsed = parse_request(payload, request, error_offset);
  if (parsed != Error::no_error) return parsed;
  error_offset = payload.size();
  if (payload.size() > kMaxHostPayload) return Error::client_request_too_long;
  return Error::no_error;
}

}  // namespace romi
}  // namespace tether
