// protobuf's JSON mapping with the type descriptions kept (json_mapping.hpp): util::JsonStringToMessage and
// util::MessageToJsonString as protobuf 3.21 writes them, their type resolver replaced by one that
// describes each type once; and a direct path for the plain cases (see Direct below).
#include "tether/rpc/json_mapping.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/reflection.h>
#include <google/protobuf/type.pb.h>
#include <google/protobuf/util/type_resolver.h>
#include <google/protobuf/util/type_resolver_util.h>

#include <charconv>
#include <cstdint>
#include <limits>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace tether::rpc {

namespace pb = google::protobuf;

namespace {
// The prefix of the type URLs protobuf's JSON functions use.
constexpr char kTypeUrlPrefix[] = "type.googleapis.com";

std::string type_url(const pb::Message& message) {
  return std::string(kTypeUrlPrefix) + "/" + message.GetDescriptor()->full_name();
}
}  // namespace

// A resolver of the pool's types that describes each one once (the descriptions are copied out: the
// converter takes them by value).
class JsonMapping::Types final : public pb::util::TypeResolver {
 public:
  explicit Types(const pb::DescriptorPool& pool)
      : resolver_(pb::util::NewTypeResolverForDescriptorPool(kTypeUrlPrefix, &pool)) {}

  pb::util::Status ResolveMessageType(const std::string& url, pb::Type* type) override {
    return resolve(url, type, messages_, [&](pb::Type* out) { return resolver_->ResolveMessageType(url, out); });
  }
  pb::util::Status ResolveEnumType(const std::string& url, pb::Enum* type) override {
    return resolve(url, type, enums_, [&](pb::Enum* out) { return resolver_->ResolveEnumType(url, out); });
  }

 private:
  template <typename Description, typename Resolve>
  pb::util::Status resolve(const std::string& url, Description* out, std::map<std::string, Description, std::less<>>& cache,
                           Resolve&& resolve_once) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      const auto found = cache.find(url);
      if (found != cache.end()) {
        *out = found->second;
        return pb::util::Status();
      }
    }
    Description resolved;
    const pb::util::Status status = resolve_once(&resolved);
    if (!status.ok()) return status;  // not kept: an unknown type stays an error each time
    const std::lock_guard<std::mutex> lock(mutex_);
    *out = cache.emplace(url, std::move(resolved)).first->second;
    return status;
  }

  std::unique_ptr<pb::util::TypeResolver> resolver_;
  std::mutex mutex_;
  std::map<std::string, pb::Type, std::less<>> messages_;
  std::map<std::string, pb::Enum, std::less<>> enums_;
};

// The direct path: messages of plain types converted with reflection, without the converter's object
// writers and its google.protobuf.Type descriptions. It only takes what it writes or reads exactly as
// protobuf does, and hands the rest to protobuf (`false`: nothing was written or kept):
//   - plain types: proto3, every field (at any depth) an integer, bool, enum or string, singular or
//     repeated, or a message of a plain type that is not one of protobuf's well-known types; no map, no
//     oneof (nor proto3 `optional`), no float, double or bytes;
//   - printing without whitespace, enums by name: fields in declaration order when every primitive is
//     printed (repeated ones as []), otherwise in field-number order with defaults left out; a set message
//     recursively (an unset one never); strings of printable ASCII with nothing protobuf escapes;
//   - parsing the JSON a program writes for them: an object whose keys are the fields' JSON or proto
//     names, each once; integers in range without fraction or exponent (as numbers or strings), true and
//     false, enum names, strings without escapes or control or non-ASCII characters, nested objects, arrays.
// Anything else (an unknown or repeated key, null, a number as a string, an escape, bad JSON, ...) goes
// to protobuf, which gives the exact result or error.
class JsonMapping::Direct {
 public:
  // Whether `type` is plain (looked at once per type).
  bool plain(const pb::Descriptor* type) {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::vector<const pb::Descriptor*> seen;
    return plain_locked(type, seen);
  }

  static bool print(const pb::Message& message, std::string& json, bool all_primitives) {
    const std::size_t start = json.size();
    if (print_message(message, json, all_primitives, 0)) return true;
    json.resize(start);
    return false;
  }

  // Two passes: the first only checks that the direct path takes all of `json` (the message untouched
  // otherwise, as protobuf's refusal leaves it), the second replaces the message's content.
  static bool parse(std::string_view json, pb::Message& message) {
    if (!parse_all(json, message.GetDescriptor(), nullptr)) return false;
    message.Clear();
    return parse_all(json, message.GetDescriptor(), &message);
  }

 private:
  static constexpr int kMaxDepth = 32;

  bool plain_locked(const pb::Descriptor* type, std::vector<const pb::Descriptor*>& seen) {
    if (const auto known = plain_.find(type); known != plain_.end()) return known->second;
    for (const pb::Descriptor* visiting : seen) {
      if (visiting == type) return true;  // recursive: decided by the outermost visit
    }
    seen.push_back(type);
    bool plain = type->file()->syntax() == pb::FileDescriptor::SYNTAX_PROTO3 && type->oneof_decl_count() == 0 &&
                 type->extension_range_count() == 0 && type->file()->package() != "google.protobuf" &&
                 !type->options().map_entry();
    for (int i = 0; plain && i < type->field_count(); ++i) {
      const pb::FieldDescriptor* field = type->field(i);
      switch (field->cpp_type()) {
        case pb::FieldDescriptor::CPPTYPE_INT32:
        case pb::FieldDescriptor::CPPTYPE_INT64:
        case pb::FieldDescriptor::CPPTYPE_UINT32:
        case pb::FieldDescriptor::CPPTYPE_UINT64:
        case pb::FieldDescriptor::CPPTYPE_BOOL:
        case pb::FieldDescriptor::CPPTYPE_ENUM:
          break;
        case pb::FieldDescriptor::CPPTYPE_STRING:
          plain = field->type() == pb::FieldDescriptor::TYPE_STRING;
          break;
        case pb::FieldDescriptor::CPPTYPE_MESSAGE:
          plain = !field->is_map() && field->type() == pb::FieldDescriptor::TYPE_MESSAGE &&
                  plain_locked(field->message_type(), seen);
          break;
        default:
          plain = false;
          break;
      }
      if (field->real_containing_oneof() != nullptr || field->has_optional_keyword() || field->is_required()) plain = false;
    }
    seen.pop_back();
    if (seen.empty() || !plain) plain_.emplace(type, plain);
    return plain;
  }

  // --- printing ----------------------------------------------------------------------------------------

  static bool print_string(const std::string& text, std::string& json) {
    for (const char c : text) {
      // Printable ASCII that protobuf's JSON escaping leaves as it is.
      if (c < 0x20 || c > 0x7E || c == '"' || c == '\\' || c == '<' || c == '>' || c == '&' || c == '\'' || c == '=') {
        return false;
      }
    }
    json += '"';
    json += text;
    json += '"';
    return true;
  }

  template <typename Integer>
  static void print_integer(Integer value, std::string& json, bool quoted) {
    char digits[24];
    const auto end = std::to_chars(digits, digits + sizeof digits, value).ptr;
    if (quoted) json += '"';
    json.append(digits, static_cast<std::size_t>(end - digits));
    if (quoted) json += '"';
  }

  // One value of `field` (element `index` of a repeated one).
  static bool print_value(const pb::Message& message, const pb::FieldDescriptor* field, int index, std::string& json,
                          bool all_primitives, int depth) {
    const pb::Reflection& r = *message.GetReflection();
    const bool repeated = field->is_repeated();
    switch (field->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_INT32:
        print_integer(repeated ? r.GetRepeatedInt32(message, field, index) : r.GetInt32(message, field), json, false);
        return true;
      case pb::FieldDescriptor::CPPTYPE_UINT32:
        print_integer(repeated ? r.GetRepeatedUInt32(message, field, index) : r.GetUInt32(message, field), json, false);
        return true;
      case pb::FieldDescriptor::CPPTYPE_INT64:
        print_integer(repeated ? r.GetRepeatedInt64(message, field, index) : r.GetInt64(message, field), json, true);
        return true;
      case pb::FieldDescriptor::CPPTYPE_UINT64:
        print_integer(repeated ? r.GetRepeatedUInt64(message, field, index) : r.GetUInt64(message, field), json, true);
        return true;
      case pb::FieldDescriptor::CPPTYPE_BOOL:
        json += (repeated ? r.GetRepeatedBool(message, field, index) : r.GetBool(message, field)) ? "true" : "false";
        return true;
      case pb::FieldDescriptor::CPPTYPE_ENUM: {
        const int number = repeated ? r.GetRepeatedEnumValue(message, field, index) : r.GetEnumValue(message, field);
        const pb::EnumValueDescriptor* value = field->enum_type()->FindValueByNumber(number);
        if (value == nullptr) return false;  // a number the enum does not name: protobuf's
        return print_string(value->name(), json);
      }
      case pb::FieldDescriptor::CPPTYPE_STRING: {
        std::string scratch;
        const std::string& text = repeated ? r.GetRepeatedStringReference(message, field, index, &scratch)
                                           : r.GetStringReference(message, field, &scratch);
        return print_string(text, json);
      }
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        return print_message(repeated ? r.GetRepeatedMessage(message, field, index) : r.GetMessage(message, field), json,
                             all_primitives, depth + 1);
      default:
        return false;
    }
  }

  static bool print_field(const pb::Message& message, const pb::FieldDescriptor* field, std::string& json,
                          bool all_primitives, int depth, bool& first) {
    json += first ? "\"" : ",\"";
    first = false;
    json += field->json_name();
    json += "\":";
    if (!field->is_repeated()) return print_value(message, field, 0, json, all_primitives, depth);
    json += '[';
    const int size = message.GetReflection()->FieldSize(message, field);
    for (int i = 0; i < size; ++i) {
      if (i != 0) json += ',';
      if (!print_value(message, field, i, json, all_primitives, depth)) return false;
    }
    json += ']';
    return true;
  }

  static bool print_message(const pb::Message& message, std::string& json, bool all_primitives, int depth) {
    if (depth > kMaxDepth) return false;
    const pb::Reflection& r = *message.GetReflection();
    if (!r.GetUnknownFields(message).empty()) return false;
    json += '{';
    bool first = true;
    if (all_primitives) {
      const pb::Descriptor* type = message.GetDescriptor();
      for (int i = 0; i < type->field_count(); ++i) {
        const pb::FieldDescriptor* field = type->field(i);
        if (!field->is_repeated() && field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE && !r.HasField(message, field)) {
          continue;
        }
        if (!print_field(message, field, json, all_primitives, depth, first)) return false;
      }
    } else {
      std::vector<const pb::FieldDescriptor*> fields;
      r.ListFields(message, &fields);  // the set ones, by number
      for (const pb::FieldDescriptor* field : fields) {
        if (!print_field(message, field, json, all_primitives, depth, first)) return false;
      }
    }
    json += '}';
    return true;
  }

  // --- parsing -----------------------------------------------------------------------------------------

  struct Reader {
    const char* at;
    const char* end;
    void skip_space() {
      while (at != end && (*at == ' ' || *at == '\t' || *at == '\n' || *at == '\r')) ++at;
    }
    bool take(char c) {
      skip_space();
      if (at == end || *at != c) return false;
      ++at;
      return true;
    }
    bool peek(char c) {
      skip_space();
      return at != end && *at == c;
    }
    // A string without escapes, control or non-ASCII characters.
    bool string(std::string_view& out) {
      if (!take('"')) return false;
      const char* start = at;
      while (at != end && *at != '"') {
        if (*at < 0x20 || *at > 0x7E || *at == '\\') return false;
        ++at;
      }
      if (at == end) return false;
      out = std::string_view(start, static_cast<std::size_t>(at - start));
      ++at;
      return true;
    }
    // An integer: -?(0|[1-9][0-9]*), no fraction or exponent after it, within Integer's range; as a number
    // or as a string (protobuf takes both).
    template <typename Integer>
    bool integer(Integer& value) {
      skip_space();
      if (at != end && *at == '"') {
        ++at;
        if (!unquoted_integer(value)) return false;
        if (at == end || *at != '"') return false;
        ++at;
        return true;
      }
      return unquoted_integer(value);
    }
    template <typename Integer>
    bool unquoted_integer(Integer& value) {
      const char* start = at;
      if (at != end && *at == '-') ++at;
      if (at == end || *at < '0' || *at > '9') return false;
      if (*at == '0' && at + 1 != end && at[1] >= '0' && at[1] <= '9') return false;
      while (at != end && *at >= '0' && *at <= '9') ++at;
      if (at != end && (*at == '.' || *at == 'e' || *at == 'E')) return false;
      if (at - start == 2 && start[0] == '-' && start[1] == '0') return false;  // -0: protobuf's
      const auto parsed = std::from_chars(start, at, value);
      return parsed.ec == std::errc() && parsed.ptr == at;
    }
    bool literal(std::string_view word) {
      skip_space();
      if (static_cast<std::size_t>(end - at) < word.size() || std::string_view(at, word.size()) != word) return false;
      const char* after = at + word.size();
      if (after != end && ((*after >= 'a' && *after <= 'z') || (*after >= 'A' && *after <= 'Z') ||
                           (*after >= '0' && *after <= '9') || *after == '_')) {
        return false;  // a longer word: protobuf's to judge
      }
      at = after;
      return true;
    }
  };

  static bool parse_all(std::string_view json, const pb::Descriptor* type, pb::Message* message) {
    Reader in{json.data(), json.data() + json.size()};
    if (!parse_message(in, type, message, 0)) return false;
    in.skip_space();
    return in.at == in.end;
  }

  // One value of `field` into `message` (null: only read).
  static bool parse_value(Reader& in, pb::Message* message, const pb::FieldDescriptor* field, int depth) {
    const bool repeated = field->is_repeated();
    switch (field->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_INT32: {
        std::int32_t value = 0;
        if (!in.integer(value)) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddInt32(message, field, value) : r.SetInt32(message, field, value);
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_UINT32: {
        std::uint32_t value = 0;
        if (!in.integer(value)) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddUInt32(message, field, value) : r.SetUInt32(message, field, value);
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_INT64: {
        std::int64_t value = 0;
        if (!in.integer(value)) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddInt64(message, field, value) : r.SetInt64(message, field, value);
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_UINT64: {
        std::uint64_t value = 0;
        if (!in.integer(value)) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddUInt64(message, field, value) : r.SetUInt64(message, field, value);
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_BOOL: {
        bool value = false;
        if (in.literal("true")) {
          value = true;
        } else if (!in.literal("false")) {
          return false;
        }
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddBool(message, field, value) : r.SetBool(message, field, value);
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_ENUM: {
        std::string_view name;
        if (!in.string(name)) return false;
        const pb::EnumValueDescriptor* value = field->enum_type()->FindValueByName(std::string(name));
        if (value == nullptr) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddEnumValue(message, field, value->number()) : r.SetEnumValue(message, field, value->number());
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_STRING: {
        std::string_view text;
        if (!in.string(text)) return false;
        if (message != nullptr) {
          const pb::Reflection& r = *message->GetReflection();
          repeated ? r.AddString(message, field, std::string(text)) : r.SetString(message, field, std::string(text));
        }
        return true;
      }
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        if (message == nullptr) return parse_message(in, field->message_type(), nullptr, depth + 1);
        return parse_message(in, field->message_type(),
                             repeated ? message->GetReflection()->AddMessage(message, field)
                                      : message->GetReflection()->MutableMessage(message, field),
                             depth + 1);
      default:
        return false;
    }
  }

  // An object of `type` into `message` (null: only read).
  static bool parse_message(Reader& in, const pb::Descriptor* type, pb::Message* message, int depth) {
    if (depth > kMaxDepth || !in.take('{')) return false;
    std::uint64_t seen_small = 0;  // fields met, by index (a key twice is protobuf's to judge)
    std::vector<bool> seen_large;
    if (in.take('}')) return true;
    for (;;) {
      std::string_view key;
      if (!in.string(key) || !in.take(':')) return false;
      const pb::FieldDescriptor* field = find_field(type, key);
      if (field == nullptr) return false;
      const int index = field->index();
      if (index < 64) {
        if ((seen_small >> index & 1u) != 0) return false;
        seen_small |= std::uint64_t{1} << index;
      } else {
        if (seen_large.empty()) seen_large.resize(static_cast<std::size_t>(type->field_count()));
        if (seen_large[static_cast<std::size_t>(index)]) return false;
        seen_large[static_cast<std::size_t>(index)] = true;
      }
      if (field->is_repeated()) {
        if (!in.take('[')) return false;
        if (!in.take(']')) {
          for (;;) {
            if (!parse_value(in, message, field, depth)) return false;
            if (in.take(']')) break;
            if (!in.take(',')) return false;
          }
        }
      } else if (!parse_value(in, message, field, depth)) {
        return false;
      }
      if (in.take('}')) return true;
      if (!in.take(',')) return false;
    }
  }

  static const pb::FieldDescriptor* find_field(const pb::Descriptor* type, std::string_view key) {
    for (int i = 0; i < type->field_count(); ++i) {
      const pb::FieldDescriptor* field = type->field(i);
      if (field->json_name() == key || field->name() == key) return field;
    }
    return nullptr;
  }

  std::mutex mutex_;
  std::unordered_map<const pb::Descriptor*, bool> plain_;
};

JsonMapping::JsonMapping(const pb::DescriptorPool& pool)
    : types_(std::make_unique<Types>(pool)), direct_(std::make_unique<Direct>()) {}
JsonMapping::~JsonMapping() = default;

pb::util::Status JsonMapping::from_json(std::string_view json, pb::Message& message,
                                        const pb::util::JsonParseOptions& options) const {
  if (!options.ignore_unknown_fields && !options.case_insensitive_enum_parsing &&
      direct_->plain(message.GetDescriptor()) && Direct::parse(json, message)) {
    return pb::util::Status();
  }
  std::string binary;
  pb::util::Status status = pb::util::JsonToBinaryString(types_.get(), type_url(message),
                                                         pb::StringPiece(json.data(), json.size()), &binary, options);
  if (status.ok() && !message.ParseFromString(binary)) {
    status = pb::util::InvalidArgumentError("JSON transcoder produced invalid protobuf output.");
  }
  return status;
}

pb::util::Status JsonMapping::to_json(const pb::Message& message, std::string& json,
                                      const pb::util::JsonPrintOptions& options) const {
  if (!options.add_whitespace && !options.always_print_enums_as_ints && !options.preserve_proto_field_names &&
      direct_->plain(message.GetDescriptor()) &&
      Direct::print(message, json, options.always_print_primitive_fields)) {
    return pb::util::Status();
  }
  return pb::util::BinaryToJsonString(types_.get(), type_url(message), message.SerializeAsString(), &json, options);
}

}  // namespace tether::rpc
