// Proxy and Elcano messages as text (see message_text.hpp).
#include "message_text.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <cctype>
#include <cstdint>
#include <limits>
#include <set>

#include "cli_support.hpp"
#include "tether/core/utf8.hpp"
#include "tether/elcano/decoder.hpp"

namespace tether::cli {

namespace {

namespace pb = google::protobuf;

// Lowercase without '-' and '_': `safe-position`, `safePosition`, `safe_position` all match.
std::string normalised(std::string_view name) {
  std::string text;
  for (const char c : name) {
    if (c == '-' || c == '_') continue;
    text += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return text;
}

// The oneof a message carries its alternatives in (`data` in both schemas).
const pb::OneofDescriptor* data_oneof(const pb::Descriptor* descriptor) {
  const pb::OneofDescriptor* oneof = descriptor->FindOneofByName("data");
  return oneof != nullptr ? oneof : (descriptor->oneof_decl_count() > 0 ? descriptor->oneof_decl(0) : nullptr);
}

std::string list_names(const pb::OneofDescriptor* oneof) {
  std::string names;
  for (int i = 0; i < oneof->field_count(); ++i) names += (i == 0 ? "" : ", ") + kebab_case(oneof->field(i)->name());
  return names;
}

std::string list_fields(const pb::Descriptor* descriptor) {
  std::string names;
  for (int i = 0; i < descriptor->field_count(); ++i) {
    names += (i == 0 ? "" : ", ") + kebab_case(descriptor->field(i)->name());
  }
  return names.empty() ? "none" : names;
}

std::string value_hint(const pb::FieldDescriptor* field) {
  switch (field->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_BOOL:
      return "BOOL";
    case pb::FieldDescriptor::CPPTYPE_ENUM:
      return "NAME";
    default:
      return "N";
  }
}

std::optional<bool> parse_bool(std::string_view text) {
  const std::string word = normalised(text);
  if (word == "true" || word == "1" || word == "on" || word == "high" || word == "yes") return true;
  if (word == "false" || word == "0" || word == "off" || word == "low" || word == "no") return false;
  return std::nullopt;
}

// Sets `field` of `message` from `text`; false (and `error`) when the value does not fit the field.
bool set_field(pb::Message& message, const pb::FieldDescriptor* field, std::string_view text,
               const std::string& message_name, std::string& error) {
  const pb::Reflection* reflection = message.GetReflection();
  const std::string name = kebab_case(field->name());
  auto bad = [&](const std::string& expected) {
    error = message_name + ": " + name + " needs " + expected + ", got '" + std::string(text) + "'";
    return false;
  };
  switch (field->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_UINT32: {
      const auto value = parse_signed(text, 0, std::numeric_limits<std::uint32_t>::max());
      if (!value) return bad("a number 0..4294967295");
      reflection->SetUInt32(&message, field, static_cast<std::uint32_t>(*value));
      return true;
    }
    case pb::FieldDescriptor::CPPTYPE_INT32: {
      const auto value =
          parse_signed(text, std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max());
      if (!value) return bad("a number -2147483648..2147483647");
      reflection->SetInt32(&message, field, static_cast<std::int32_t>(*value));
      return true;
    }
    case pb::FieldDescriptor::CPPTYPE_UINT64: {
      const auto value = parse_signed(text, 0, std::numeric_limits<std::int64_t>::max());
      if (!value) return bad("a non-negative number");
      reflection->SetUInt64(&message, field, static_cast<std::uint64_t>(*value));
      return true;
    }
    case pb::FieldDescriptor::CPPTYPE_INT64: {
      const auto value =
          parse_signed(text, std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max());
      if (!value) return bad("a number");
      reflection->SetInt64(&message, field, *value);
      return true;
    }
    case pb::FieldDescriptor::CPPTYPE_BOOL: {
      const auto value = parse_bool(text);
      if (!value) return bad("true or false (1/0, on/off, high/low)");
      reflection->SetBool(&message, field, *value);
      return true;
    }
    case pb::FieldDescriptor::CPPTYPE_ENUM: {
      const pb::EnumDescriptor* type = field->enum_type();
      for (int i = 0; i < type->value_count(); ++i) {
        if (normalised(type->value(i)->name()) == normalised(text)) {
          reflection->SetEnum(&message, field, type->value(i));
          return true;
        }
      }
      if (const auto number =
              parse_signed(text, std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max())) {
        if (const pb::EnumValueDescriptor* value = type->FindValueByNumber(static_cast<int>(*number))) {
          reflection->SetEnum(&message, field, value);
          return true;
        }
      }
      std::string names;
      for (int i = 0; i < type->value_count(); ++i) names += (i == 0 ? "" : ", ") + type->value(i)->name();
      return bad("one of " + names);
    }
    default:
      error = message_name + ": field " + name + " cannot be set from the command line";
      return false;
  }
}

// Servo positions are degrees 0..180 in both schemas (the deployed host sends degrees; Servo::write would
// take 544 and more as microseconds, a unit this command does not offer): a value outside is a typo.
bool is_servo_degrees_field(const pb::FieldDescriptor* field) {
  const std::string& message = field->containing_type()->name();
  return (message == "ServoInit" && field->name() == "safePosition") ||
         (message == "ServoControl" && field->name() == "position");
}

// Fills `root` (an ArduinoIn of either schema) from the words; see parse_proxy_command.
bool fill(pb::Message& root, std::span<const std::string> words, ProxyCommand& command, std::string& error) {
  const pb::OneofDescriptor* oneof = data_oneof(root.GetDescriptor());
  const std::string& wanted = words[0];
  const pb::FieldDescriptor* alternative = nullptr;
  for (int i = 0; oneof != nullptr && i < oneof->field_count(); ++i) {
    if (normalised(oneof->field(i)->name()) == normalised(wanted)) alternative = oneof->field(i);
  }
  if (alternative == nullptr || alternative->message_type() == nullptr) {
    error = "unknown message '" + wanted + "' (messages: " + (oneof != nullptr ? list_names(oneof) : "none") + ")";
    return false;
  }
  command.name = kebab_case(alternative->name());
  pb::Message* body = root.GetReflection()->MutableMessage(&root, alternative);
  const pb::Descriptor* descriptor = body->GetDescriptor();
  std::set<int> given;
  for (std::size_t i = 1; i < words.size(); ++i) {
    const std::string& word = words[i];
    const std::size_t equals = word.find('=');
    if (equals == std::string::npos || equals == 0) {
      error = command.name + ": expected FIELD=VALUE, got '" + word + "' (fields: " + list_fields(descriptor) + ")";
      return false;
    }
    const std::string name = word.substr(0, equals);
    const pb::FieldDescriptor* field = nullptr;
    for (int f = 0; f < descriptor->field_count(); ++f) {
      if (normalised(descriptor->field(f)->name()) == normalised(name)) field = descriptor->field(f);
    }
    if (field == nullptr || field->is_repeated() || field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
      error = command.name + ": unknown field '" + name + "' (fields: " + list_fields(descriptor) + ")";
      return false;
    }
    if (!given.insert(field->number()).second) {
      error = command.name + ": " + kebab_case(field->name()) + " given twice";
      return false;
    }
    const std::string_view value = std::string_view(word).substr(equals + 1);
    if (!set_field(*body, field, value, command.name, error)) return false;
    if (is_servo_degrees_field(field)) {
      const std::int32_t degrees = body->GetReflection()->GetInt32(*body, field);
      if (degrees < 0 || degrees > 180) {
        error = command.name + ": " + kebab_case(field->name()) + " needs degrees 0..180, got '" + std::string(value) +
                "'";
        return false;
      }
    }
    if (field->name() == "pin" && field->cpp_type() == pb::FieldDescriptor::CPPTYPE_UINT32) {
      command.pin = body->GetReflection()->GetUInt32(*body, field);
    }
  }
  for (int f = 0; f < descriptor->field_count(); ++f) {
    if (given.count(descriptor->field(f)->number()) == 0) {
      error = command.name + ": missing " + kebab_case(descriptor->field(f)->name()) + "=" +
              value_hint(descriptor->field(f)) + " (every field must be given)";
      return false;
    }
  }
  command.reset = alternative->message_type()->name() == "Reset";
  return true;
}

}  // namespace

std::string printable(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  text.reserve(bytes.size());
  const auto escape = [&](unsigned char byte) {
    text += "\\x";
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0x0F];
  };
  const auto* const data = reinterpret_cast<const std::uint8_t*>(bytes.data());
  std::size_t i = 0;
  while (i < bytes.size()) {
    const std::uint8_t lead = data[i];
    if (lead >= 0x20 && lead < 0x7F) {
      text += static_cast<char>(lead);
      ++i;
      continue;
    }
    // Controls are escaped: C0 and DEL (single bytes) and C1 (U+0080..U+009F, C2 80..C2 9F).
    std::size_t length = lead < 0x80 ? 0 : utf8_sequence_length(data, bytes.size(), i);
    if (length == 2 && lead == 0xC2 && data[i + 1] < 0xA0) length = 0;
    if (length == 0) {
      escape(lead);
      ++i;
      continue;
    }
    text.append(bytes.substr(i, length));
    i += length;
  }
  return text;
}

std::string kebab_case(std::string_view camel) {
  std::string text;
  for (std::size_t i = 0; i < camel.size(); ++i) {
    const char c = camel[i];
    if (std::isupper(static_cast<unsigned char>(c))) {
      if (i > 0 && camel[i - 1] != '_') text += '-';
      text += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else {
      text += c == '_' ? '-' : c;
    }
  }
  return text;
}

std::optional<ProxyCommand> parse_proxy_command(proxy::Mode mode, std::span<const std::string> words,
                                                std::string& error) {
  if (words.empty()) {
    error = "no message given";
    return std::nullopt;
  }
  ProxyCommand command;
  if (mode == proxy::Mode::primary) {
    proxy::ArduinoIn message;
    if (!fill(message, words, command, error)) return std::nullopt;
    command.message = std::move(message);
  } else {
    RocketryProto::ArduinoIn message;
    if (!fill(message, words, command, error)) return std::nullopt;
    command.message = std::move(message);
  }
  return command;
}

// g++ 12 at -O2/-O3 (Release) reports a -Wrestrict overlap inside libstdc++'s operator+ for
// `" " + std::string + ...` that cannot happen (GCC bug 105329); silenced for this function only.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
std::string proxy_message_list(proxy::Mode mode, std::string_view indent) {
  const pb::Descriptor* root =
      mode == proxy::Mode::primary ? proxy::ArduinoIn::descriptor() : RocketryProto::ArduinoIn::descriptor();
  const pb::OneofDescriptor* oneof = data_oneof(root);
  std::string text;
  for (int i = 0; oneof != nullptr && i < oneof->field_count(); ++i) {
    const pb::FieldDescriptor* alternative = oneof->field(i);
    if (alternative->message_type() == nullptr) continue;
    text += indent;
    text += kebab_case(alternative->name());
    const pb::Descriptor* body = alternative->message_type();
    for (int f = 0; f < body->field_count(); ++f) {
      text += " " + kebab_case(body->field(f)->name()) + "=" + value_hint(body->field(f));
    }
    text += '\n';
  }
  return text;
}
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic pop
#endif

std::string describe_proxy_message(const pb::Message& message) {
  const pb::OneofDescriptor* oneof = data_oneof(message.GetDescriptor());
  const pb::FieldDescriptor* field =
      oneof != nullptr ? message.GetReflection()->GetOneofFieldDescriptor(message, oneof) : nullptr;
  if (field == nullptr) return "(no data) " + message.ShortDebugString();
  std::string text = field->name();
  if (field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
    const std::string body = message.GetReflection()->GetMessage(message, field).ShortDebugString();
    if (!body.empty()) text += " " + body;
  }
  return text;
}

nlohmann::ordered_json proxy_message_json(const pb::Message& message) {
  nlohmann::ordered_json object;
  const pb::OneofDescriptor* oneof = data_oneof(message.GetDescriptor());
  const pb::FieldDescriptor* field =
      oneof != nullptr ? message.GetReflection()->GetOneofFieldDescriptor(message, oneof) : nullptr;
  object["type"] = field != nullptr ? field->name() : std::string();
  pb::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  std::string text;
  const pb::Message& body = field != nullptr && field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE
                                ? message.GetReflection()->GetMessage(message, field)
                                : message;
  if (pb::util::MessageToJsonString(body, &text, options).ok()) {
    object["fields"] = nlohmann::ordered_json::parse(text, nullptr, false);
  } else {
    object["fields"] = nlohmann::ordered_json::object();
  }
  return object;
}

std::optional<elcano::Message> parse_elcano(std::string_view text, std::string& error) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  elcano::Error first = elcano::Error::success;
  for (const elcano::Generation generation : {elcano::Generation::b, elcano::Generation::d}) {
    LinkCounters counters;
    elcano::Decoder<256> reader(generation, counters);
    DecodeStatus status = DecodeStatus::more;
    for (const char c : text) {
      status = reader.feed(static_cast<std::uint8_t>(c));
      if (status != DecodeStatus::more) break;
    }
    if (status == DecodeStatus::more) status = reader.feed('\n');
    if (status == DecodeStatus::frame) return reader.frame();
    if (first == elcano::Error::success) {
      first = status == DecodeStatus::error ? reader.error() : elcano::Error::bad_lcurly;
    }
  }
  error = std::string("not an Elcano message (") + elcano::describe(first) +
          "): expected e.g. D{s 50}{a 25}, S{s 1}{a 2}{b 3}{p 4,5}, G{n 1}{p 0,0}{b 90}";
  return std::nullopt;
}

std::string format_elcano(const elcano::Message& message, elcano::Generation generation) {
  std::uint8_t buffer[160];
  const Result<std::size_t> written = elcano::encode_message(message, generation, MutableByteView(buffer));
  if (!written.ok()) return "?";
  std::size_t size = written.value();
  while (size > 0 && (buffer[size - 1] == '\n' || buffer[size - 1] == '\r')) --size;
  return std::string(reinterpret_cast<const char*>(buffer), size);
}

nlohmann::ordered_json elcano_json(const elcano::Message& message) {
  nlohmann::ordered_json object = {{"type", elcano::to_string(message.type)}};
  const std::pair<const char*, std::int32_t> fields[] = {
      {"n", message.number},  {"s", message.speed},       {"a", message.angle},   {"o", message.obstacle},
      {"b", message.bearing}, {"r", message.probability}, {"east", message.east}, {"north", message.north}};
  for (const auto& [name, value] : fields) {
    if (value != elcano::kUnset) object[name] = value;
  }
  return object;
}

std::optional<elcano::TypeSet> parse_elcano_types(std::string_view text) {
  elcano::TypeSet set;
  if (text.empty() || text == "none") return set;
  while (!text.empty()) {
    const std::size_t comma = text.find(',');
    const std::string_view word = text.substr(0, comma);
    elcano::Type type;
    if (!elcano::type_from_name(ByteView::from_chars(word.data(), word.size()), type)) {
      return std::nullopt;
    }
    set = set.with(type);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return set;
}

}  // namespace tether::cli
