// Parsing a device's message whatever bytes its strings hold (see device_message.hpp).
#include "tether/proxy/device_message.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/unknown_field_set.h>

#include <cstddef>
#include <string>
#include <string_view>

namespace tether::proxy {
namespace {

namespace pb = google::protobuf;

// Deeper than any message of the schemas; bounds the recursion on hostile input.
constexpr int kMaxDepth = 32;

// The length of the well-formed UTF-8 sequence at `at` (RFC 3629), or 0.
std::size_t utf8_sequence(std::string_view text, std::size_t at) {
  const auto byte = [&](std::size_t i) { return i < text.size() ? static_cast<unsigned char>(text[i]) : 0u; };
  const auto continuation = [&](std::size_t i) { return (byte(i) & 0xC0u) == 0x80u; };
  const unsigned lead = byte(at);
  if (lead < 0x80) return 1;
  if (lead >= 0xC2 && lead <= 0xDF) return continuation(at + 1) ? 2 : 0;
  if (lead >= 0xE0 && lead <= 0xEF) {
    if (!continuation(at + 1) || !continuation(at + 2)) return 0;
    if (lead == 0xE0 && byte(at + 1) < 0xA0) return 0;   // overlong
    if (lead == 0xED && byte(at + 1) >= 0xA0) return 0;  // surrogate
    return 3;
  }
  if (lead >= 0xF0 && lead <= 0xF4) {
    if (!continuation(at + 1) || !continuation(at + 2) || !continuation(at + 3)) return 0;
    if (lead == 0xF0 && byte(at + 1) < 0x90) return 0;   // overlong
    if (lead == 0xF4 && byte(at + 1) >= 0x90) return 0;  // above U+10FFFF
    return 4;
  }
  return 0;
}

bool is_utf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t length = utf8_sequence(text, i);
    if (length == 0) return false;
    i += length;
  }
  return true;
}

std::string escape_non_utf8(std::string_view text) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string escaped;
  escaped.reserve(text.size() + 8);
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t length = utf8_sequence(text, i);
    if (length != 0) {
      escaped.append(text.substr(i, length));
      i += length;
      continue;
    }
    const auto byte = static_cast<unsigned char>(text[i++]);
    escaped += "\\x";
    escaped += kDigits[byte >> 4];
    escaped += kDigits[byte & 0x0F];
  }
  return escaped;
}

// Rewrites the string fields of `fields` (a message of `type`, read without its schema) that are not
// UTF-8, in nested messages too. False when a nested message is not well-formed.
bool repair(const pb::Descriptor& type, pb::UnknownFieldSet& fields, int depth) {
  if (depth > kMaxDepth) return false;
  for (int i = 0; i < fields.field_count(); ++i) {
    pb::UnknownField& field = *fields.mutable_field(i);
    if (field.type() != pb::UnknownField::TYPE_LENGTH_DELIMITED) continue;
    const pb::FieldDescriptor* descriptor = type.FindFieldByNumber(field.number());
    if (descriptor == nullptr) continue;
    if (descriptor->type() == pb::FieldDescriptor::TYPE_STRING) {
      std::string& text = *field.mutable_length_delimited();
      if (!is_utf8(text)) text = escape_non_utf8(text);
    } else if (descriptor->type() == pb::FieldDescriptor::TYPE_MESSAGE) {
      pb::UnknownFieldSet inner;
      if (!inner.ParseFromString(field.length_delimited())) return false;
      if (!repair(*descriptor->message_type(), inner, depth + 1)) return false;
      if (!inner.SerializeToString(field.mutable_length_delimited())) return false;
    }
  }
  return true;
}

}  // namespace

bool parse_device_message(pb::Message& message, ByteView payload) {
  const int size = static_cast<int>(payload.size());
  {
    const pb::LogSilencer quiet;  // libprotobuf logs the invalid UTF-8 it refuses
    if (message.ParseFromArray(payload.data(), size)) return true;
  }
  pb::UnknownFieldSet fields;
  if (!fields.ParseFromArray(payload.data(), size)) return false;
  if (!repair(*message.GetDescriptor(), fields, 0)) return false;
  std::string repaired;
  if (!fields.SerializeToString(&repaired)) return false;
  const pb::LogSilencer quiet;
  return message.ParseFromString(repaired);
}

}  // namespace tether::proxy
