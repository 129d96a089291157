// Parsing a device's message whatever bytes its strings hold (see device_message.hpp).
#include "tether/proxy/device_message.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/unknown_field_set.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "tether/core/utf8.hpp"

namespace tether::proxy {
namespace {

namespace pb = google::protobuf;

// Deeper than any message of the schemas; bounds the recursion on hostile input.
constexpr int kMaxDepth = 32;

// The length of the well-formed UTF-8 sequence at `at`, or 0.
std::size_t utf8_sequence(std::string_view text, std::size_t at) {
  return utf8_sequence_length(reinterpret_cast<const std::uint8_t*>(text.data()), text.size(), at);
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
