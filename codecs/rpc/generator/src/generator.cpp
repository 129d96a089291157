#include "tether/rpc/generator.hpp"

#include "generated_files.hpp"

#include <google/protobuf/descriptor.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace tether::rpc {
namespace {

namespace pb = google::protobuf;

bool is_identifier(std::string_view name) {
  if (name.empty() || (name[0] >= '0' && name[0] <= '9')) return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    if (!ok) return false;
  }
  return true;
}

// The overhead the envelope adds around a method's payload, at most (varints at their longest):
// HostMessage{id (1+5), body (1+2){method (1+5), request (1+2), period_ms (1+5)}} = 24;
// DeviceMessage{body (1+2){stream or call (1+5), seq (1+5), payload (1+2)}} = 18.
constexpr int kRequestOverhead = 24;
constexpr int kAnswerOverhead = 18;

// "MAX(a, MAX(b, c))" of nanopb size macros (or a constant when `names` is empty).
std::string max_of(const std::vector<std::string>& names, const std::string& none) {
  if (names.empty()) return none;
  std::string out = names.back();
  for (std::size_t i = names.size() - 1; i-- > 0;) out = "TETHER_RPC_MAX(" + names[i] + ", " + out + ")";
  return out;
}

// A full protobuf name as nanopb's C name (`arm.Outer.Inner` -> `arm_Outer_Inner`).
std::string c_name(std::string name) {
  for (char& c : name) {
    if (c == '.') c = '_';
  }
  return name;
}

// The C names nanopb gives the types of the schema's files (and the macros it derives from them), each with
// what has it: a service code whose names meet one of them does not build, nor does nanopb's code when two
// types meet. The library's own names are checked against them before anything is written.
class NanopbNames {
 public:
  NanopbNames(const Schema& schema, std::string where) : where_(std::move(where)) {
    std::vector<const pb::FileDescriptor*> files;
    collect_files(*schema.service().file(), files);
    for (const pb::FileDescriptor* file : files) {
      if (!carries_code(file->name())) continue;
      for (int i = 0; i < file->message_type_count(); ++i) add_message(*file->message_type(i));
      for (int i = 0; i < file->enum_type_count(); ++i) add_enum(*file->enum_type(i));
    }
  }

  // Refuses `id`, the library's `what`, when nanopb's code has it too; `other_fix` is the library's side of
  // the remedy.
  void refuse_taken(const std::string& id, const std::string& what, const std::string& other_fix) const {
    auto found = types_.find(id);
    if (found == types_.end()) {
      found = derived_.find(id);
      if (found == derived_.end()) return;
    }
    const std::string& owner = found->second;  // "message a.B", "enum value a.C": its kind, then its name
    throw SchemaError(where_ + what + " " + id + " is also nanopb's name of " + owner + ": rename the " +
                      owner.substr(0, owner.rfind(' ')) + ", or " + other_fix);
  }

 private:
  void claim(const std::string& id, const std::string& what) {
    // The kit's own nanopb code (the envelope, package tether.rpc.wire) and codec functions use the prefix.
    if (id.rfind("tether_rpc_", 0) == 0) {
      throw SchemaError(where_ + what + " becomes " + id +
                        " in nanopb's C code, and names starting tether_rpc_ are the kit's: use another package");
    }
    const auto [known, added] = types_.emplace(id, what);
    if (!added) {
      throw SchemaError(where_ + known->second + " and " + what + " both become " + id +
                        " in nanopb's C code: rename one of them");
    }
  }

  void add_enum(const pb::EnumDescriptor& type) {
    const std::string id = c_name(type.full_name());
    claim(id, "enum " + type.full_name());
    // nanopb's long names (its default): the enum's name, then the value's.
    for (int i = 0; i < type.value_count(); ++i) claim(id + "_" + type.value(i)->name(), "enum value " + type.value(i)->full_name());
  }

  void add_message(const pb::Descriptor& type) {
    const std::string id = c_name(type.full_name());
    const std::string what = "message " + type.full_name();
    claim(id, what);
    for (const char* suffix : {"_init_default", "_init_zero", "_fields", "_msg", "_size", "_FIELDLIST", "_CALLBACK",
                               "_DEFAULT"}) {
      derived_.emplace(id + suffix, what);
    }
    for (int i = 0; i < type.field_count(); ++i) {
      derived_.emplace(id + "_" + type.field(i)->name() + "_tag", what);
      if (type.field(i)->message_type() != nullptr) derived_.emplace(id + "_" + type.field(i)->name() + "_MSGTYPE", what);
    }
    for (int i = 0; i < type.nested_type_count(); ++i) add_message(*type.nested_type(i));
    for (int i = 0; i < type.enum_type_count(); ++i) add_enum(*type.enum_type(i));
  }

  std::string where_;
  std::map<std::string, std::string> types_;    // a type's or enum value's C name -> what has it
  std::map<std::string, std::string> derived_;  // nanopb's macros of a message -> the message
};

// Refuses a message the methods reach that contains itself: nanopb makes the field that closes the loop a
// callback (it has no size bound), which the device's codec does not carry.
void refuse_recursion(const Schema& schema, const std::string& where) {
  std::vector<const pb::Descriptor*> path;
  std::set<const pb::Descriptor*> done;
  const auto visit = [&](const auto& self, const pb::Descriptor* type) -> void {
    if (done.count(type) != 0) return;
    path.push_back(type);
    for (int i = 0; i < type->field_count(); ++i) {
      const pb::FieldDescriptor& field = *type->field(i);
      const pb::Descriptor* inner = field.message_type();
      if (inner == nullptr) continue;
      for (const pb::Descriptor* outer : path) {
        if (outer != inner) continue;
        throw SchemaError(where + field.full_name() + ": a recursive field (" + inner->full_name() + " contains " +
                          inner->full_name() + " through it): nanopb makes it a callback, which the device does " +
                          "not carry; nest messages of other types, one per level");
      }
      self(self, inner);
    }
    path.pop_back();
    done.insert(type);
  };
  for (const Method& method : schema.methods()) {
    visit(visit, method.input);
    visit(visit, method.output);
  }
}

// What the generated code of `schema` would not build with: a recursive message, two types with one C
// name, the library's names (its class, its service struct, the handlers) taken by nanopb's code.
void check_device_schema(const Schema& schema, const std::string& name) {
  const std::string where = schema.file().filename().string() + ": ";
  refuse_recursion(schema, where);
  const NanopbNames names(schema, where);
  const std::string other_name = "give the library another name (--name)";
  names.refuse_taken(name, "the library's class", other_name);
  names.refuse_taken(name + "Service", "the library's service struct", other_name);
  for (const Method& method : schema.methods()) {
    names.refuse_taken(handler_name(schema, method), "the handler",
                       "the method " + schema.service().name() + "." + method.name);
  }
}

}  // namespace

bool carries_code(const std::string& file) {
  return file != "nanopb.proto" && file != "google/protobuf/descriptor.proto";
}

void collect_files(const pb::FileDescriptor& file, std::vector<const pb::FileDescriptor*>& files) {
  for (const pb::FileDescriptor* known : files) {
    if (known == &file) return;
  }
  for (int i = 0; i < file.dependency_count(); ++i) collect_files(*file.dependency(i), files);
  files.push_back(&file);
}

std::string nanopb_name(const pb::Descriptor& type) { return c_name(type.full_name()); }

Schema load_schema_to_serve(const std::filesystem::path& file, const SchemaOptions& options, std::string_view option) {
  try {
    return Schema::load(file, options);
  } catch (const SchemaError& e) {
    // Schema::load's refusal of a file with several services asks for a choice: say how to make it.
    const std::string_view message = e.what();
    constexpr std::string_view kChoose = ": name the one to serve";
    if (!options.service.empty() || !message.ends_with(kChoose)) throw;
    throw SchemaError(std::string(message) + " with " + std::string(option) + " NAME");
  }
}

std::string default_library_name(const Schema& schema) { return schema.service().name() + "Rpc"; }

std::string handler_name(const Schema& schema, const Method& method) {
  return schema.service().name() + "_" + method.name;
}

ServiceCode service_code(const Schema& schema, std::string_view name_view, std::string_view nanopb_header) {
  const std::string name(name_view);
  if (!is_identifier(name)) throw SchemaError("library name \"" + name + "\" is not a C++ identifier");
  check_device_schema(schema, name);
  const std::string service = name + "Service";
  const std::string origin = "Generated by `tether generate` from " + schema.file().filename().string() +
                             " (service " + schema.service().full_name() + ", schema hash " +
                             format_hash(schema.hash()) + "): do not edit.";

  // Every message type a method uses, once, for the size checks.
  std::vector<const pb::Descriptor*> types;
  const auto add_type = [&](const pb::Descriptor* type) {
    for (const pb::Descriptor* known : types) {
      if (known == type) return;
    }
    types.push_back(type);
  };
  std::vector<std::string> requests, stream_requests, replies, unary_replies;
  int streams = 0;
  for (const Method& method : schema.methods()) {
    add_type(method.input);
    add_type(method.output);
    requests.push_back(nanopb_name(*method.input) + "_size");
    replies.push_back(nanopb_name(*method.output) + "_size");
    if (method.streaming) {
      ++streams;
      stream_requests.push_back(nanopb_name(*method.input) + "_size");
    } else {
      unary_replies.push_back(nanopb_name(*method.output) + "_size");
    }
  }

  std::ostringstream h;
  h << "// " << origin << "\n"
    << "// The device's service: the handlers the application defines, and the table the runtime serves.\n"
    << "#pragma once\n\n"
    << "#include <stddef.h>\n#include <stdint.h>\n\n"
    << "#include \"" << nanopb_header << "\"\n"
    << "#include \"tether/rpc/device/rpc_device.hpp\"\n\n";
  for (const pb::Descriptor* type : types) {
    const std::string c = nanopb_name(*type);
    h << "#ifndef " << c << "_size\n"
      << "#error \"" << type->full_name()
      << " has no size bound: give its strings, bytes and repeated fields nanopb bounds (a .options file beside "
      << schema.file().filename().string() << ")\"\n"
      << "#endif\n";
  }
  h << "\n/// The handlers, one per method of " << schema.service().full_name()
    << ": fill the reply (for a stream: the next message) and return tether::rpc::Status::ok(), or\n"
    << "/// tether::rpc::Status::error(code, \"text\") with a code in 1..0xFEFF.\n";
  for (const Method& method : schema.methods()) {
    h << "tether::rpc::Status " << handler_name(schema, method) << "(const " << nanopb_name(*method.input)
      << "& request, " << nanopb_name(*method.output) << (method.streaming ? "& next);\n" : "& reply);\n");
  }
  // The methods' structs, for the room the runtime keeps for a request and a reply (on its stack).
  std::ostringstream structs;
  structs << "  /// Any method's request struct (the runtime's room for one).\n  union Requests {\n";
  for (std::size_t i = 0; i < schema.methods().size(); ++i) {
    structs << "    " << nanopb_name(*schema.methods()[i].input) << " m" << i << ";\n";
  }
  structs << "  };\n  /// Any method's reply struct.\n  union Replies {\n";
  for (std::size_t i = 0; i < schema.methods().size(); ++i) {
    structs << "    " << nanopb_name(*schema.methods()[i].output) << " m" << i << ";\n";
  }
  structs << "  };\n";
  h << "\n#define TETHER_RPC_MAX(a, b) ((a) > (b) ? (a) : (b))\n"
    << "// A length-delimited field of at most n bytes: its key, its length, the bytes.\n"
    << "#define TETHER_RPC_DELIMITED(n) (2 + (n) + ((n) > 127) + ((n) > 16383))\n\n"
    << "/// " << schema.service().full_name() << " as the device runtime serves it.\n"
    << "struct " << service << " {\n"
    << structs.str()
    << "  /// The hash the device's hello carries (tether::rpc::Schema::hash of " << schema.file().filename().string()
    << ").\n"
    << "  static constexpr uint64_t kSchemaHash = " << format_hash(schema.hash()) << "ull;\n"
    << "  /// The runtime's table sizes, from nanopb's bounds of the schema's messages.\n"
    << "  struct Limits {\n"
    << "    static constexpr size_t kMaxPayload = " << kRequestOverhead << " + " << max_of(requests, "0") << ";\n"
    << "    static constexpr uint8_t kStreams = " << (streams == 0 ? 1 : streams) << ";\n"
    << "    static constexpr uint8_t kStreamRequestBytes = TETHER_RPC_MAX(1, " << max_of(stream_requests, "0")
    << ");\n"
    << "    static constexpr uint8_t kDuplicateDepth = 4;  // the host's id window (tether::rpc::kIdWindow)\n"
    << "    static constexpr size_t kMaxOutPayload = TETHER_RPC_MAX(64, " << kAnswerOverhead << " + "
    << max_of(replies, "0") << ");\n"
    << "    static constexpr uint16_t kReplyCacheBytes = TETHER_RPC_MAX(tether::rpc::device::kErrorAnswerBytes, "
       "TETHER_RPC_DELIMITED("
    << max_of(unary_replies, "0") << "));\n"
    << "    static constexpr size_t kRequestStructBytes = sizeof(Requests);\n"
    << "    static constexpr size_t kReplyStructBytes = sizeof(Replies);\n"
    << "  };\n"
    << "  /// The runtime for this service.\n"
    << "  using Device = tether::rpc::device::Device<Limits>;\n"
    << "  /// The method table (in flash on the AVR).\n"
    << "  static const tether::rpc::device::Service kService;\n"
    << "  /// The method table, as a constant: a global device is constant-initialised (no start-up code).\n"
    << "  static constexpr const tether::rpc::device::Service& service() { return kService; }\n"
    << "};\n\n";
  for (const std::string& request : requests) {
    h << "static_assert(" << request << " <= 64, \"" << request
      << ": a request is at most 64 bytes (the envelope's bound)\");\n";
  }

  // Every message type the methods reach through their fields: each gets its encoder and decoder
  // (tether/rpc/device/message_codec.hpp, from nanopb's field lists).
  std::vector<const pb::Descriptor*> reached;
  const auto reach = [&](const auto& self, const pb::Descriptor* type) -> void {
    for (const pb::Descriptor* known : reached) {
      if (known == type) return;
    }
    reached.push_back(type);
    for (int i = 0; i < type->field_count(); ++i) {
      if (type->field(i)->message_type() != nullptr) self(self, type->field(i)->message_type());
    }
  };
  for (const pb::Descriptor* type : types) reach(reach, type);

  std::ostringstream cpp;
  cpp << "// " << origin << "\n"
      << "#include \"" << name << "_service.h\"\n\n"
      << "// The messages' encoders and decoders (nanopb's structs and rules, without its generic code).\n";
  for (const pb::Descriptor* type : reached) cpp << "TETHER_RPC_MESSAGE_DECLARE(" << nanopb_name(*type) << ")\n";
  for (const pb::Descriptor* type : reached) cpp << "TETHER_RPC_MESSAGE_DEFINE(" << nanopb_name(*type) << ")\n";
  cpp << "\nnamespace {\n\n";
  for (const Method& method : schema.methods()) {
    cpp << "tether::rpc::Status call_" << method.name << "(const void* request, void* reply) {\n"
        << "  return " << handler_name(schema, method) << "(*static_cast<const " << nanopb_name(*method.input)
        << "*>(request), *static_cast<" << nanopb_name(*method.output) << "*>(reply));\n"
        << "}\n\n";
  }
  cpp << "const tether::rpc::device::Method kMethods[] TETHER_IN_FLASH = {\n";
  for (const Method& method : schema.methods()) {
    cpp << "    {&tether_rpc_decode_" << nanopb_name(*method.input) << ", &tether_rpc_encode_" << nanopb_name(*method.output) << ", &call_"
        << method.name << ", " << (method.streaming ? "true" : "false") << "},\n";
  }
  cpp << "};\n\n"
      << "}  // namespace\n\n"
      << "const tether::rpc::device::Service " << service << "::kService TETHER_IN_FLASH = {" << service
      << "::kSchemaHash, kMethods, " << schema.methods().size() << "};\n";
  return ServiceCode{h.str(), cpp.str()};
}

std::vector<std::filesystem::path> write_service_code(const Schema& schema, std::string_view name,
                                                      const std::filesystem::path& directory) {
  const std::string base(name);
  const std::string header = schema.file().stem().string() + ".pb.h";
  const ServiceCode code = service_code(schema, base, header);
  return write_generated_files(
      directory, {{base + "_service.h", &code.header}, {base + "_service.cpp", &code.source}});
}

std::vector<std::filesystem::path> write_generated_files(
    const std::filesystem::path& directory, const std::vector<std::pair<std::string, const std::string*>>& files) {
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) throw std::runtime_error(directory.string() + ": " + error.message());
  std::vector<std::filesystem::path> written;
  for (const auto& [file, text] : files) {
    const std::filesystem::path path = directory / file;
    std::ofstream out(path, std::ios::binary);
    out << *text;
    if (!out) throw std::runtime_error(path.string() + ": cannot be written");
    written.push_back(path);
  }
  return written;
}

}  // namespace tether::rpc
