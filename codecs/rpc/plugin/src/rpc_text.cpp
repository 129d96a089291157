// The rpc codec's texts for the `tether` command: see rpc_text.hpp.
#include "rpc_text.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/util/json_util.h>

#include <fnmatch.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <utility>
#include <variant>

#include "cli_support.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/rpc/plugin.hpp"
#include "tether_rpc.pb.h"

namespace tether::cli {

namespace {

namespace pb = google::protobuf;

// `"text"`: quoted for messages, safe on a terminal (printable) and as JSON.
std::string rpc_quoted(std::string_view text) { return dump(nlohmann::ordered_json(printable(text))); }

std::string rpc_field_names(const pb::Descriptor& type) {
  std::string names;
  for (int i = 0; i < type.field_count(); ++i) names += (i > 0 ? ", " : "") + type.field(i)->name();
  return names.empty() ? "none" : names;
}

const pb::FieldDescriptor* rpc_find_field(const pb::Descriptor& type, std::string_view name) {
  for (int i = 0; i < type.field_count(); ++i) {
    const pb::FieldDescriptor* field = type.field(i);
    if (field->name() == name || field->json_name() == name) return field;
  }
  return nullptr;
}

template <typename Integer>
std::optional<Integer> rpc_parse_integer(std::string_view text) {
  Integer value{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text.empty()) return std::nullopt;
  return value;
}

std::optional<double> rpc_parse_number(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return value;
}

// `text` as base64, protobuf's JSON form of bytes (what the replies print): the standard or the URL-safe
// alphabet, padding optional. Nothing when it is not base64.
std::optional<std::string> rpc_base64_decode(std::string_view text) {
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  if (text.size() % 4 == 1) return std::nullopt;
  std::string bytes;
  std::uint32_t bits = 0;
  int count = 0;
  for (const char c : text) {
    std::uint32_t value = 0;
    if (c >= 'A' && c <= 'Z') {
      value = static_cast<std::uint32_t>(c - 'A');
    } else if (c >= 'a' && c <= 'z') {
      value = static_cast<std::uint32_t>(c - 'a') + 26;
    } else if (c >= '0' && c <= '9') {
      value = static_cast<std::uint32_t>(c - '0') + 52;
    } else if (c == '+' || c == '-') {
      value = 62;
    } else if (c == '/' || c == '_') {
      value = 63;
    } else {
      return std::nullopt;
    }
    bits = (bits << 6) | value;
    count += 6;
    if (count >= 8) {
      count -= 8;
      bytes += static_cast<char>((bits >> count) & 0xFF);
    }
  }
  return bytes;
}

// Sets one scalar field from its typed text; what is wrong otherwise.
std::optional<std::string> rpc_set_field(pb::Message& message, const pb::FieldDescriptor& field,
                                         const std::string& value) {
  const pb::Reflection& reflection = *message.GetReflection();
  const auto bad = [&](std::string_view expected) {
    return std::optional<std::string>(field.name() + "=" + rpc_quoted(value) + ": expected " + std::string(expected));
  };
  switch (field.cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_INT32: {
      const auto parsed = rpc_parse_integer<std::int32_t>(value);
      if (!parsed) return bad("an integer in -2147483648..2147483647");
      reflection.SetInt32(&message, &field, *parsed);
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_INT64: {
      const auto parsed = rpc_parse_integer<std::int64_t>(value);
      if (!parsed) return bad("a 64-bit integer");
      reflection.SetInt64(&message, &field, *parsed);
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_UINT32: {
      const auto parsed = rpc_parse_integer<std::uint32_t>(value);
      if (!parsed) return bad("an integer in 0..4294967295");
      reflection.SetUInt32(&message, &field, *parsed);
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_UINT64: {
      const auto parsed = rpc_parse_integer<std::uint64_t>(value);
      if (!parsed) return bad("an unsigned 64-bit integer");
      reflection.SetUInt64(&message, &field, *parsed);
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_DOUBLE: {
      const auto parsed = rpc_parse_number(value);
      if (!parsed) return bad("a number");
      reflection.SetDouble(&message, &field, *parsed);
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_FLOAT: {
      const auto parsed = rpc_parse_number(value);
      if (!parsed || (std::isfinite(*parsed) && std::fabs(*parsed) > std::numeric_limits<float>::max()))
        return bad("a number in float's range");
      reflection.SetFloat(&message, &field, static_cast<float>(*parsed));
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_BOOL:
      if (value == "true" || value == "1") {
        reflection.SetBool(&message, &field, true);
      } else if (value == "false" || value == "0") {
        reflection.SetBool(&message, &field, false);
      } else {
        return bad("true or false");
      }
      return std::nullopt;
    case pb::FieldDescriptor::CPPTYPE_STRING:
      if (field.type() == pb::FieldDescriptor::TYPE_BYTES) {
        // As the JSON form takes them and the reply prints them, so printed bytes can be given back.
        const auto bytes = rpc_base64_decode(value);
        if (!bytes) return bad("base64 (protobuf's JSON form of bytes: AQID is 01 02 03)");
        reflection.SetString(&message, &field, *bytes);
        return std::nullopt;
      }
      reflection.SetString(&message, &field, value);
      return std::nullopt;
    case pb::FieldDescriptor::CPPTYPE_ENUM: {
      const pb::EnumDescriptor& type = *field.enum_type();
      const pb::EnumValueDescriptor* found = type.FindValueByName(value);
      if (found == nullptr) {
        if (const auto number = rpc_parse_integer<std::int32_t>(value)) found = type.FindValueByNumber(*number);
      }
      if (found == nullptr) {
        std::string names;
        for (int i = 0; i < type.value_count(); ++i) {
          names += (i > 0 ? ", " : "") + type.value(i)->name() + " (" + std::to_string(type.value(i)->number()) + ")";
        }
        return bad("a value of " + type.name() + ": " + names);
      }
      reflection.SetEnumValue(&message, &field, found->number());
      return std::nullopt;
    }
    case pb::FieldDescriptor::CPPTYPE_MESSAGE:
      break;
  }
  return field.name() + " is a message: give the whole request as JSON ('{\"" + field.json_name() + "\": {...}}')";
}

// `01 ff`: payload bytes as the monitor shows them.
std::string rpc_hex(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  for (const char c : bytes) {
    const auto byte = static_cast<std::uint8_t>(c);
    if (!text.empty()) text += ' ';
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0x0F];
  }
  return text;
}

// What the host's side of a `--tap` monitor saw: message id -> method index, for the device's side.
// Process-wide: one monitor per process. Bounded: the oldest ids go first.
class RpcCallsSeen {
 public:
  static RpcCallsSeen& instance() {
    static RpcCallsSeen seen;
    return seen;
  }
  void add(std::uint32_t id, std::uint32_t method) {
    std::lock_guard lock(mutex_);
    if (methods_.size() >= 256) methods_.erase(methods_.begin());
    methods_[id] = method;
  }
  std::optional<std::uint32_t> find(std::uint32_t id) const {
    std::lock_guard lock(mutex_);
    const auto found = methods_.find(id);
    if (found == methods_.end()) return std::nullopt;
    return found->second;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::uint32_t, std::uint32_t> methods_;
};

class RpcMonitorDecoder final : public MonitorDecoder {
 public:
  RpcMonitorDecoder(std::shared_ptr<const rpc::Schema> schema, const DecoderRole& role)
      : schema_(std::move(schema)), direction_(role.direction), decoder_(proxy::Integrity::crc16, counters_) {
    if (schema_) factory_ = std::make_unique<pb::DynamicMessageFactory>(&schema_->pool());
  }

  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    if (!feed_frame(decoder_, counters_, byte, [](proxy::FrameError error) { return proxy::describe(error); }, records)) {
      return;
    }
    const ByteView payload = decoder_.frame();
    const std::string bytes(reinterpret_cast<const char*>(payload.data()), payload.size());
    const bool decoded = direction_ == Direction::host_to_device ? host_record(bytes, records) : device_record(bytes, records);
    if (!decoded) {
      const std::string hex = rpc_hex(bytes);
      records.push_back({"undecodable", hex, {{"payload_hex", hex}}, false});
    }
  }

  LinkCounters counters() const override { return counters_; }

 private:
  // The method of index `index` in the schema, or null.
  const rpc::Method* method(std::uint32_t index) const {
    if (!schema_ || index >= schema_->methods().size()) return nullptr;
    return &schema_->methods()[index];
  }
  // The only method of that kind, when the schema has exactly one.
  const rpc::Method* only_method(bool streaming) const {
    if (!schema_) return nullptr;
    const rpc::Method* only = nullptr;
    for (const rpc::Method& m : schema_->methods()) {
      if (m.streaming != streaming) continue;
      if (only != nullptr) return nullptr;
      only = &m;
    }
    return only;
  }
  // `bytes` as a message of `type` into `object[key]` and `text`; false when they do not parse.
  bool payload(const pb::Descriptor* type, const std::string& bytes, nlohmann::ordered_json& object, std::string& text) {
    if (type == nullptr || !factory_) return false;
    std::unique_ptr<pb::Message> message(factory_->GetPrototype(type)->New());
    if (!message->ParseFromString(bytes)) return false;
    text += " " + rpc_message_json(*message);
    object["fields"] = rpc_message_value(*message);
    return true;
  }
  void raw(const std::string& bytes, nlohmann::ordered_json& object, std::string& text) {
    const std::string hex = rpc_hex(bytes);
    text += " bytes [" + hex + "]";
    object["payload_hex"] = hex;
  }
  void body(const rpc::Method* m, const pb::Descriptor* type, const std::string& bytes, nlohmann::ordered_json& object,
            std::string& text) {
    if (m != nullptr) {
      object["method"] = m->name;
      text += " " + m->name;
    }
    if (!payload(type, bytes, object, text)) raw(bytes, object, text);
  }

  bool host_record(const std::string& bytes, std::vector<MonitorRecord>& records) {
    rpc::wire::HostMessage message;
    if (!message.ParseFromString(bytes)) return false;
    nlohmann::ordered_json object = {{"message", ""}, {"id", message.id()}};
    std::string text;
    switch (message.body_case()) {
      case rpc::wire::HostMessage::kHello:
        text = "hello";
        break;
      case rpc::wire::HostMessage::kCall: {
        RpcCallsSeen::instance().add(message.id(), message.call().method());
        const rpc::Method* m = method(message.call().method());
        text = "call";
        object["method_index"] = message.call().method();
        body(m, m != nullptr ? m->input : nullptr, message.call().request(), object, text);
        break;
      }
      case rpc::wire::HostMessage::kOpen: {
        RpcCallsSeen::instance().add(message.id(), message.open().method());
        const rpc::Method* m = method(message.open().method());
        text = "open-stream";
        object["method_index"] = message.open().method();
        object["period_ms"] = message.open().period_ms();
        body(m, m != nullptr ? m->input : nullptr, message.open().request(), object, text);
        text += " every " + std::to_string(message.open().period_ms()) + " ms";
        break;
      }
      case rpc::wire::HostMessage::kClose:
        text = "close-stream " + std::to_string(message.close().stream());
        object["stream"] = message.close().stream();
        break;
      case rpc::wire::HostMessage::kPing:
        text = "ping";
        break;
      case rpc::wire::HostMessage::kReset:
        text = "reset";
        break;
      case rpc::wire::HostMessage::BODY_NOT_SET:
        text = "empty";
        break;
    }
    object["message"] = text.substr(0, text.find(' '));
    records.push_back({"message", text + " (id " + std::to_string(message.id()) + ")", object, true});
    return true;
  }

  bool device_record(const std::string& bytes, std::vector<MonitorRecord>& records) {
    rpc::wire::DeviceMessage message;
    if (!message.ParseFromString(bytes)) return false;
    nlohmann::ordered_json object;
    std::string text;
    const auto seen_method = [&](std::uint32_t id, bool streaming) {
      if (const auto index = RpcCallsSeen::instance().find(id)) {
        if (const rpc::Method* m = method(*index); m != nullptr && m->streaming == streaming) return m;
      }
      return only_method(streaming);
    };
    switch (message.body_case()) {
      case rpc::wire::DeviceMessage::kAck:
        text = "ack " + std::to_string(message.ack().id()) + (message.ack().refused() ? " refused" : "");
        object = {{"message", "ack"}, {"id", message.ack().id()}, {"refused", message.ack().refused()}};
        break;
      case rpc::wire::DeviceMessage::kReply: {
        const rpc::Method* m = seen_method(message.reply().call(), false);
        text = "reply " + std::to_string(message.reply().call());
        object = {{"message", "reply"}, {"call", message.reply().call()}};
        body(m, m != nullptr ? m->output : nullptr, message.reply().reply(), object, text);
        break;
      }
      case rpc::wire::DeviceMessage::kError:
        text = "device-error " + std::to_string(message.error().call()) + ": " + std::to_string(message.error().code()) +
               " " + rpc_quoted(message.error().text());
        object = {{"message", "device-error"},
                  {"call", message.error().call()},
                  {"code", message.error().code()},
                  {"text", message.error().text()}};
        break;
      case rpc::wire::DeviceMessage::kStream: {
        const rpc::Method* m = seen_method(message.stream().stream(), true);
        text = "stream " + std::to_string(message.stream().stream()) + " #" + std::to_string(message.stream().seq());
        object = {{"message", "stream"}, {"stream", message.stream().stream()}, {"seq", message.stream().seq()}};
        body(m, m != nullptr ? m->output : nullptr, message.stream().message(), object, text);
        break;
      }
      case rpc::wire::DeviceMessage::kHello: {
        const rpc::wire::DeviceHello& hello = message.hello();
        text = "device-hello session " + std::to_string(hello.session()) + " schema " + rpc::format_hash(hello.schema_hash());
        object = {{"message", "device-hello"},       {"session", hello.session()},
                  {"schema_hash", rpc::format_hash(hello.schema_hash())}, {"max_payload", hello.max_payload()},
                  {"methods", hello.methods()}};
        if (schema_) {
          const bool same = hello.schema_hash() == schema_->hash();
          text += same ? " (this schema)" : " (not this schema: " + rpc::format_hash(schema_->hash()) + ")";
          object["same_schema"] = same;
        }
        break;
      }
      case rpc::wire::DeviceMessage::kReset:
        text = "reset-event session " + std::to_string(message.reset().session());
        object = {{"message", "reset-event"}, {"session", message.reset().session()}};
        break;
      case rpc::wire::DeviceMessage::BODY_NOT_SET:
        text = "empty";
        object = {{"message", "empty"}};
        break;
    }
    records.push_back({"message", text, object, true});
    return true;
  }

  std::shared_ptr<const rpc::Schema> schema_;
  std::unique_ptr<pb::DynamicMessageFactory> factory_;
  Direction direction_;
  LinkCounters counters_;
  proxy::Decoder<rpc::kMaxPayload> decoder_;
};

}  // namespace

std::optional<std::string> fill_rpc_request(pb::Message& request, std::span<const std::string> words) {
  const pb::Descriptor& type = *request.GetDescriptor();
  if (words.size() == 1 && words[0].starts_with("{")) {
    const auto parsed = pb::util::JsonStringToMessage(pb::StringPiece(words[0].data(), words[0].size()), &request);
    if (!parsed.ok()) return "the request as JSON (" + type.name() + "): " + std::string(parsed.message());
    return std::nullopt;
  }
  std::set<const pb::FieldDescriptor*> given;
  for (const std::string& word : words) {
    const std::size_t equals = word.find('=');
    if (word.starts_with("{")) return "a JSON request is the only argument after the method (" + rpc_quoted(word) + ")";
    if (equals == std::string::npos || equals == 0) {
      return "expected FIELD=VALUE, got " + rpc_quoted(word);
    }
    const std::string name = word.substr(0, equals);
    const pb::FieldDescriptor* field = rpc_find_field(type, name);
    if (field == nullptr) {
      return type.name() + " has no field " + rpc_quoted(name) + " (fields: " + rpc_field_names(type) + ")";
    }
    if (field->is_repeated()) {
      return field->name() + " is repeated: give the whole request as JSON ('{\"" + field->json_name() + "\": [...]}')";
    }
    if (!given.insert(field).second) return field->name() + " is given twice";
    if (auto error = rpc_set_field(request, *field, word.substr(equals + 1))) return error;
  }
  return std::nullopt;
}

RpcBounds::RpcBounds(const rpc::Schema& schema) {
  const std::filesystem::path folder = schema.file().parent_path();
  std::vector<const pb::FileDescriptor*> pending;
  for (const rpc::Method& m : schema.methods()) pending.push_back(m.input->file());
  while (!pending.empty()) {
    const pb::FileDescriptor* file = pending.back();
    pending.pop_back();
    if (files_.count(file->name()) != 0) continue;
    for (int i = 0; i < file->dependency_count(); ++i) pending.push_back(file->dependency(i));
    File& bounds = files_[file->name()];
    const std::filesystem::path options = (folder / file->name()).replace_extension(".options");
    bounds.name = std::filesystem::path(file->name()).replace_extension(".options").string();
    std::ifstream in(options);
    for (std::string text; std::getline(in, text);) {
      text = text.substr(0, text.find('#'));
      std::istringstream words(text);
      Line line;
      if (!(words >> line.pattern)) continue;
      for (std::string option; words >> option;) {
        const std::size_t colon = option.find(':');
        if (colon == std::string::npos) continue;
        const std::string key = option.substr(0, colon);
        if (key != "max_size" && key != "max_length" && key != "max_count") continue;  // only these bound sizes
        if (const auto value = rpc_parse_integer<std::uint64_t>(std::string_view(option).substr(colon + 1))) {
          line.values[key] = *value;
        }
      }
      if (!line.values.empty()) bounds.lines.push_back(std::move(line));
    }
  }
}

std::optional<std::string> RpcBounds::check(const pb::Message& message) const { return check(message, ""); }

std::optional<std::string> RpcBounds::check(const pb::Message& message, const std::string& path) const {
  const pb::Descriptor& type = *message.GetDescriptor();
  const pb::Reflection& reflection = *message.GetReflection();
  const auto found = files_.find(type.file()->name());
  for (int i = 0; i < type.field_count(); ++i) {
    const pb::FieldDescriptor& field = *type.field(i);
    const std::string name = path + field.name();
    // As nanopb's generator: every line whose pattern matches the message or the field, in order.
    std::map<std::string, std::uint64_t> bound;
    if (found != files_.end()) {
      const std::string message_name = type.full_name();
      const std::string field_name = message_name + "." + field.name();
      for (const Line& line : found->second.lines) {
        if (::fnmatch(line.pattern.c_str(), message_name.c_str(), 0) != 0 &&
            ::fnmatch(line.pattern.c_str(), field_name.c_str(), 0) != 0) {
          continue;
        }
        for (const auto& [key, value] : line.values) bound[key] = value;
      }
    }
    const auto over = [&](const std::string& what, const std::string& key, const std::string& rule) {
      return name + ": " + what + ", over its .options bound (" + found->second.name + ": " + key + ":" +
             std::to_string(bound.at(key)) + rule + ")";
    };
    // A string or bytes value against max_length / max_size; what is wrong, else nothing.
    const auto check_value = [&](const std::string& value) -> std::optional<std::string> {
      const bool string = field.type() == pb::FieldDescriptor::TYPE_STRING;
      if (string && bound.count("max_length") != 0) {
        if (value.size() > bound.at("max_length")) return over(std::to_string(value.size()) + " bytes", "max_length", "");
      } else if (bound.count("max_size") != 0) {
        // A string's max_size counts its terminator.
        const std::uint64_t most = string ? (bound.at("max_size") > 0 ? bound.at("max_size") - 1 : 0) : bound.at("max_size");
        if (value.size() > most) {
          return over(std::to_string(value.size()) + " bytes", "max_size",
                      string ? ", a string of at most " + std::to_string(most) + " bytes" : "");
        }
      }
      return std::nullopt;
    };
    const bool text = field.cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING;
    const bool nested = field.cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE;
    if (field.is_repeated()) {
      const int count = reflection.FieldSize(message, &field);
      if (bound.count("max_count") != 0 && static_cast<std::uint64_t>(count) > bound.at("max_count")) {
        return over(std::to_string(count) + " values", "max_count", "");
      }
      for (int j = 0; j < count; ++j) {
        std::optional<std::string> error;
        if (text) error = check_value(reflection.GetRepeatedString(message, &field, j));
        if (nested) error = check(reflection.GetRepeatedMessage(message, &field, j), name + "[" + std::to_string(j) + "].");
        if (error) return error;
      }
    } else if (text) {
      if (auto error = check_value(reflection.GetString(message, &field))) return error;
    } else if (nested && reflection.HasField(message, &field)) {
      if (auto error = check(reflection.GetMessage(message, &field), name + ".")) return error;
    }
  }
  return std::nullopt;
}

std::string rpc_message_json(const pb::Message& message) {
  std::string json;
  pb::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  if (!pb::util::MessageToJsonString(message, &json, options).ok()) return "{}";
  return json;
}

nlohmann::ordered_json rpc_message_value(const pb::Message& message) {
  nlohmann::ordered_json value = nlohmann::ordered_json::parse(rpc_message_json(message), nullptr, false);
  return value.is_discarded() ? nlohmann::ordered_json::object() : value;
}

std::string rpc_unknown_method(const rpc::Schema& schema, std::string_view name) {
  std::string names;
  for (const rpc::Method& m : schema.methods()) names += (names.empty() ? "" : ", ") + m.name;
  return "no method " + rpc_quoted(name) + " in " + schema.file().string() + " (methods: " + names + ")";
}

std::string rpc_method_list(const rpc::Schema& schema, std::string_view indent) {
  std::string text;
  for (const rpc::Method& m : schema.methods()) {
    text += std::string(indent) + m.name;
    for (int i = 0; i < m.input->field_count(); ++i) {
      const pb::FieldDescriptor* field = m.input->field(i);
      text += " " + field->name() + "=" + (field->is_repeated() ? "[" : "") + field->type_name() +
              (field->is_repeated() ? "]" : "");
    }
    text += m.streaming ? " (stream of " + m.output->name() + ")\n" : " -> " + m.output->name() + "\n";
  }
  return text;
}

ShellLine rpc_event_line(const rpc::Event& event) {
  namespace ev = rpc::events;
  if (const auto* established = std::get_if<ev::SessionEstablished>(&event)) {
    std::string text = "session " + std::to_string(established->session_id) + " established";
    if (established->streams_reopened > 0) text += " (" + std::to_string(established->streams_reopened) + " streams reopened)";
    return {text,
            {{"event", "session"},
             {"session_id", established->session_id},
             {"streams_reopened", established->streams_reopened},
             {"first", established->first}}};
  }
  if (const auto* reset = std::get_if<ev::ResetDetected>(&event)) {
    return {"device reset (session " + std::to_string(reset->previous) + " -> " + std::to_string(reset->current) + ")",
            {{"event", "reset"}, {"previous", reset->previous}, {"current", reset->current}}};
  }
  if (const auto* mismatch = std::get_if<ev::SchemaMismatch>(&event)) {
    return {"schema mismatch: " + mismatch->text,
            {{"event", "schema_mismatch"},
             {"device_hash", rpc::format_hash(mismatch->device_hash)},
             {"schema_hash", rpc::format_hash(mismatch->schema_hash)},
             {"text", mismatch->text}}};
  }
  if (const auto* report = std::get_if<ev::DeviceErrorReport>(&event)) {
    return {"device error " + std::to_string(report->error.code) + ": " + printable(report->error.text),
            {{"event", "device_error"}, {"code", report->error.code}, {"text", report->error.text}}};
  }
  const auto& failed = std::get<ev::LinkFailed>(event);
  return {"link failed: " + failed.error.message(), {{"event", "link_failed"}, {"error", failed.error.message()}}};
}

ShellLine rpc_device_error_line(std::string_view method, const rpc::error_code& error, const rpc::DeviceError& answer) {
  const bool refused = error == rpc::RpcError::refused;
  return {std::string(method) + ": " + (refused ? "refused " : "device error ") + std::to_string(answer.code) + ": " +
              printable(answer.text) + std::string(refused ? rpc::refusal_hint(answer.code) : ""),
          {{"method", method}, {"error", refused ? "refused" : "device_error"}, {"code", answer.code}, {"text", answer.text}}};
}

std::unique_ptr<MonitorDecoder> make_rpc_monitor_decoder(std::shared_ptr<const rpc::Schema> schema,
                                                         const DecoderRole& role) {
  return std::make_unique<RpcMonitorDecoder>(std::move(schema), role);
}

std::shared_ptr<const rpc::Schema> rpc_config_schema(const devices::DeviceConfig& config) {
  const auto* options = config.options.get_if<rpc::DeviceOptions>();
  if (options == nullptr || options->schema.empty()) return nullptr;
  // The last one read, while its file is unchanged: the shell's help and a monitor's two directions (and
  // the fuzz target's every input) read the same schema.
  static std::mutex mutex;
  static std::filesystem::path last_file;
  static std::filesystem::file_time_type last_time;
  static std::shared_ptr<const rpc::Schema> last;
  std::error_code error;
  const auto time = std::filesystem::last_write_time(options->schema, error);
  std::lock_guard lock(mutex);
  if (last && !error && last_file == options->schema && last_time == time && options->schema_options.service.empty() &&
      options->schema_options.import_paths.empty()) {
    return last;
  }
  try {
    last = std::make_shared<const rpc::Schema>(rpc::Schema::load(options->schema, options->schema_options));
  } catch (const rpc::SchemaError&) {
    return nullptr;
  }
  last_file = options->schema;
  last_time = time;
  if (!options->schema_options.service.empty() || !options->schema_options.import_paths.empty()) {
    const auto loaded = last;
    last.reset();  // kept only for the plain case
    return loaded;
  }
  return last;
}

}  // namespace tether::cli
