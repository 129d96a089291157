// The proxy codec as the `tether` command shows it (see proxy_text.hpp).
#include "proxy_text.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <cctype>
#include <cstdint>
#include <limits>
#include <set>

#include "cli_support.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/plugin.hpp"

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

std::string hex(ByteView bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  for (const std::uint8_t byte : bytes) {
    if (!text.empty()) text += ' ';
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0x0F];
  }
  return text;
}

class ProxyDecoder final : public MonitorDecoder {
 public:
  ProxyDecoder(proxy::Mode mode, const DecoderRole& role, Millis now)
      : mode_(mode),
        direction_(role.direction),
        keepalive_(role.keepalive && mode == proxy::Mode::primary),
        decoder_(mode == proxy::Mode::primary ? proxy::Integrity::crc16 : proxy::Integrity::none, counters_),
        next_ping_(now) {}

  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    if (!feed_frame(decoder_, counters_, byte, [](proxy::FrameError error) { return proxy::describe(error); }, records)) {
      return;
    }
    const ByteView payload = decoder_.frame();
    const std::unique_ptr<google::protobuf::Message> message = schema_message();
    if (!proxy::parse_device_message(*message, payload)) {
      const std::string bytes = hex(payload);
      records.push_back({"undecodable", bytes, {{"payload_hex", bytes}}, false});
      return;
    }
    records.push_back({"message", describe_proxy_message(*message), proxy_message_json(*message), true});
  }

  std::string output(Millis now) override {
    if (!keepalive_ || !tick_reached(now, next_ping_)) return {};
    next_ping_ = static_cast<Millis>(now + 1000);
    proxy::ArduinoIn ping;
    ping.set_messageid(++message_id_);
    ping.mutable_ping();
    const std::string payload = ping.SerializeAsString();
    std::uint8_t frame[proxy::max_frame_size(32)];
    const Result<std::size_t> written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                            proxy::Integrity::crc16, true, MutableByteView(frame));
    if (!written.ok()) return {};
    return std::string(reinterpret_cast<const char*>(frame), written.value());
  }

  std::optional<Duration> next_wakeup(Millis now) override {
    if (!keepalive_) return std::nullopt;
    const std::int32_t left = tick_difference(next_ping_, now);
    return left > 0 ? static_cast<Duration>(left) : 0;
  }

  LinkCounters counters() const override { return counters_; }

 private:
  // The message type of this direction in this mode's schema.
  std::unique_ptr<google::protobuf::Message> schema_message() const {
    const bool primary = mode_ == proxy::Mode::primary;
    if (direction_ == Direction::host_to_device) {
      if (primary) return std::make_unique<proxy::ArduinoIn>();
      return std::make_unique<RocketryProto::ArduinoIn>();
    }
    if (primary) return std::make_unique<proxy::ArduinoOut>();
    return std::make_unique<RocketryProto::ArduinoOut>();
  }

  proxy::Mode mode_;
  Direction direction_;
  bool keepalive_;
  LinkCounters counters_;
  proxy::Decoder<proxy::kMaxPayload> decoder_;
  Millis next_ping_;
  std::uint32_t message_id_ = 0x4d4f4e00;  // "MON": far from a client's ids
};

}  // namespace

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

ShellLine proxy_event_line(const proxy::Event& event) {
  namespace ev = proxy::events;
  if (const auto* error = std::get_if<ev::DeviceError>(&event)) {
    const bool fatal = error->level == proxy::ErrorLevel::fatal;
    return {std::string("device ") + (fatal ? "FATAL" : "error") + ": " + printable(error->text),
            {{"event", "device_error"}, {"text", error->text}, {"level", fatal ? "fatal" : "warning"}}};
  }
  if (const auto* info = std::get_if<ev::DeviceInfo>(&event)) {
    return {"info: session " + std::to_string(info->session_id) +
                (info->ping_failsafe_triggered ? ", failsafe triggered" : ""),
            {{"event", "info"},
             {"session_id", info->session_id},
             {"ping_failsafe_triggered", info->ping_failsafe_triggered}}};
  }
  if (const auto* failsafe = std::get_if<ev::FailsafeTriggered>(&event)) {
    return {"FAILSAFE triggered (no ping for 10 s)", {{"event", "failsafe"}, {"session_id", failsafe->session_id}}};
  }
  if (const auto* report = std::get_if<ev::PinReport>(&event)) {
    const char* kind = report->kind == proxy::PinKind::servo     ? "servo"
                       : report->kind == proxy::PinKind::digital ? "digital"
                                                                 : "pin";
    return {std::string(kind) + " " + std::to_string(report->pin) + " = " + std::to_string(report->value) +
                (report->failsafe ? " (failsafe)" : ""),
            {{"event", "pin"},
             {"kind", kind},
             {"pin", report->pin},
             {"value", report->value},
             {"failsafe", report->failsafe}}};
  }
  if (const auto* lost = std::get_if<ev::PinLost>(&event)) {
    return {"pin " + std::to_string(lost->pin) + " lost (silent " + std::to_string(lost->silent_ms) + " ms)",
            {{"event", "pin_lost"}, {"pin", lost->pin}, {"silent_ms", lost->silent_ms}}};
  }
  if (const auto* established = std::get_if<ev::SessionEstablished>(&event)) {
    return {"session " + std::to_string(established->session_id) + " established" +
                (established->inits > 0 ? " (" + std::to_string(established->inits) + " inits replayed)" : ""),
            {{"event", "session"},
             {"session_id", established->session_id},
             {"inits", established->inits},
             {"first", established->first}}};
  }
  if (const auto* reset = std::get_if<ev::ResetDetected>(&event)) {
    return {"device reset detected (session " + std::to_string(reset->previous_session_id) + " -> " +
                std::to_string(reset->reported_session_id) + "); recovering",
            {{"event", "reset_detected"},
             {"previous_session_id", reset->previous_session_id},
             {"reported_session_id", reset->reported_session_id}}};
  }
  if (const auto* compat = std::get_if<ev::CompatEvent>(&event)) {
    const std::string name = RocketryProto::EventTypes_Name(compat->type);
    return {"device event " + name + " " + std::to_string(compat->data),
            {{"event", "compat_event"}, {"name", name}, {"data", compat->data}}};
  }
  if (const auto* compat_error = std::get_if<ev::CompatError>(&event)) {
    const std::string name = RocketryProto::ErrorTypes_Name(compat_error->type);
    return {"device error " + name + " " + std::to_string(compat_error->data),
            {{"event", "compat_error"}, {"name", name}, {"data", compat_error->data}}};
  }
  if (const auto* state = std::get_if<ev::CompatState>(&event)) {
    return {"device state " + describe_proxy_message(state->message),
            {{"event", "compat_state"}, {"message", proxy_message_json(state->message)}}};
  }
  if (const auto* undecodable = std::get_if<ev::UndecodableMessage>(&event)) {
    return {std::string(undecodable->malformed ? "undecodable" : "unknown") + " message (" +
                std::to_string(undecodable->payload.size()) + " bytes)",
            {{"event", "undecodable"}, {"malformed", undecodable->malformed}}};
  }
  const auto& failed = std::get<ev::LinkFailed>(event);
  return {"link failed: " + failed.error.message(), {{"event", "link_failed"}, {"message", failed.error.message()}}};
}

std::unique_ptr<MonitorDecoder> make_proxy_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                           Millis now) {
  return std::make_unique<ProxyDecoder>(config.options.get<proxy::DeviceOptions>().client.mode, role, now);
}

}  // namespace tether::cli
