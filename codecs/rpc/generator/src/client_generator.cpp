// The host's typed clients (generator.hpp: client_code): one class per service, each method a member on
// protoc's classes, over a tether::rpc::Client of the compiled-in schema.
#include <google/protobuf/descriptor.h>

#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "tether/rpc/generator.hpp"

#include "generated_files.hpp"

namespace tether::rpc {
namespace {

namespace pb = google::protobuf;

// The members every client has (`client_`: the private one): a method of the same name would hide one.
const std::set<std::string> kClientMembers = {"kSchemaHash", "descriptor", "wait_ready", "async_wait_ready",
                                              "counters",    "session",    "close",      "is_open",
                                              "get_executor", "dynamic",   "client_"};

// C++20's keywords (alternative tokens included): a method cannot be a member of that name.
const std::set<std::string> kCppKeywords = {
    "alignas",  "alignof",   "and",        "and_eq",   "asm",          "auto",         "bitand",
    "bitor",    "bool",      "break",      "case",     "catch",        "char",         "char8_t",
    "char16_t", "char32_t",  "class",      "compl",    "concept",      "const",        "consteval",
    "constexpr", "constinit", "const_cast", "continue", "co_await",     "co_return",    "co_yield",
    "decltype", "default",   "delete",     "do",       "double",       "dynamic_cast", "else",
    "enum",     "explicit",  "export",     "extern",   "false",        "float",        "for",
    "friend",   "goto",      "if",         "inline",   "int",          "long",         "mutable",
    "namespace", "new",      "noexcept",   "not",      "not_eq",       "nullptr",      "operator",
    "or",       "or_eq",     "private",    "protected", "public",      "register",     "reinterpret_cast",
    "requires", "return",    "short",      "signed",   "sizeof",       "static",       "static_assert",
    "static_cast", "struct", "switch",     "template", "this",         "thread_local", "throw",
    "true",     "try",       "typedef",    "typeid",   "typename",     "union",        "unsigned",
    "using",    "virtual",   "void",       "volatile", "wchar_t",      "while",        "xor",
    "xor_eq"};

// `text` (a comment from the .proto) as `///` lines, each indented by `indent`.
std::string doc_lines(const std::string& text, const std::string& indent) {
  std::string out;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t start = line.find_first_not_of(' ');
    out += indent;
    out += "///";
    if (start != std::string::npos) {
      out += ' ';
      out.append(line, start, std::string::npos);
    }
    out += '\n';
  }
  return out;
}

template <typename Descriptor>
std::string leading_comment(const Descriptor& descriptor, const std::string& indent) {
  pb::SourceLocation location;
  if (!descriptor.GetSourceLocation(&location) || location.leading_comments.empty()) return "";
  return doc_lines(location.leading_comments, indent);
}

// `a.b` -> `a::b`.
// protoc's identifier of a file in its generated names (`descriptor_table_<it>`): letters and digits kept,
// any other byte `_` and its hex code (`split/svc.proto` -> `split_2fsvc_2eproto`).
std::string protoc_file_identifier(const std::string& file) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string identifier;
  for (const char c : file) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte >= '0' && byte <= '9') || (byte >= 'a' && byte <= 'z') || (byte >= 'A' && byte <= 'Z')) {
      identifier += c;
    } else {
      identifier += '_';
      if (byte >= 16) identifier += kHex[byte >> 4];
      identifier += kHex[byte & 15];
    }
  }
  return identifier;
}

std::string cpp_namespace(const std::string& package) {
  std::string out;
  for (const char c : package) {
    if (c == '.') {
      out += "::";
    } else {
      out += c;
    }
  }
  return out;
}

void check_names(const Schema& schema, const std::string& class_name) {
  // The class shares its namespace with the package's protoc classes (and top-level enum values).
  const std::string package = schema.service().file()->package();
  const std::string full = package.empty() ? class_name : package + "." + class_name;
  const pb::DescriptorPool& pool = *schema.service().file()->pool();
  const char* kind = pool.FindMessageTypeByName(full) != nullptr ? "message"
                     : pool.FindEnumTypeByName(full) != nullptr  ? "enum"
                     : pool.FindEnumValueByName(full) != nullptr ? "enum value"
                                                                 : nullptr;
  if (kind != nullptr) {
    throw SchemaError(schema.file().filename().string() + ": " + kind + " " + full + " has the name of service " +
                      schema.service().name() + "'s client class (" + cpp_namespace(full) +
                      ") in the same namespace: rename the " + kind);
  }
  std::set<std::string> names;
  for (const Method& method : schema.methods()) names.insert(method.name);
  for (const Method& method : schema.methods()) {
    const std::string where = schema.file().filename().string() + ": " + schema.service().name() + "." + method.name;
    if (kCppKeywords.count(method.name) != 0) {
      throw SchemaError(where + ": " + method.name + " is a C++ keyword, which cannot name a member of " + class_name +
                        ": rename the method");
    }
    if (kClientMembers.count(method.name) != 0 || method.name == class_name) {
      throw SchemaError(where + ": the name is one of " + class_name + "'s own members: rename the method");
    }
    if (names.count("async_" + method.name) != 0) {
      throw SchemaError(where + ": async_" + method.name + " is both its asynchronous form and a method");
    }
  }
}

void write_client_class(std::ostringstream& h, const Schema& schema) {
  const pb::ServiceDescriptor& service = schema.service();
  const std::string name = service.name() + "Client";
  check_names(schema, name);
  h << leading_comment(service, "")
    << "/// Typed client of service `" << service.full_name() << "`: a device built from the same schema (its hash\n"
    << "/// " << format_hash(schema.hash()) << ") answers it. Each method is a member on protoc's classes; underneath,\n"
    << "/// `dynamic()`, a `tether::rpc::Client` of the compiled-in schema (tether/rpc/client.hpp: the protocol,\n"
    << "/// errors, threading). Movable, not copyable; closes when destroyed.\n"
    << "class " << name << " {\n"
    << " public:\n"
    << "  /// The schema's hash (`tether::rpc::Schema::hash` of " << schema.file().filename().string()
    << "): the device's hello must carry it.\n"
    << "  static constexpr std::uint64_t kSchemaHash = " << format_hash(schema.hash()) << "ull;\n\n"
    << "  /// Client of the device behind `stream` (not null); starts the session at once. Throws\n"
    << "  /// std::invalid_argument for bad timing, tether::rpc::SchemaError when protoc's classes linked into\n"
    << "  /// the program come from another version of the schema.\n"
    << "  explicit " << name << "(std::shared_ptr<::tether::transports::ByteStream> stream,\n"
    << "      const ::tether::rpc::Options& options = ::tether::rpc::Options(),\n"
    << "      ::tether::rpc::Client::EventHandler handler = ::tether::rpc::Client::EventHandler());\n\n"
    << "  /// The service as protoc compiled it into the program.\n"
    << "  static const ::google::protobuf::ServiceDescriptor& descriptor();\n";
  for (const Method& method : schema.methods()) {
    const pb::MethodDescriptor& descriptor = *service.method(method.index);
    const std::string request = cpp_class_name(*method.input);
    const std::string reply = cpp_class_name(*method.output);
    const std::string quoted = "\"" + method.name + "\"";
    h << "\n"
      << "  /// `rpc " << method.name << "(" << method.input->full_name() << ") returns ("
      << (method.streaming ? "stream " : "") << method.output->full_name() << ")`.\n"
      << leading_comment(descriptor, "  ");
    if (method.streaming) {
      h << "  /// Opens the stream with `request`, one message every `period` (1..65535 ms): `handler` gets each,\n"
        << "  /// then once the error (and an empty message) if the stream ends by itself (tether::rpc::StreamHandler's\n"
        << "  /// contract). Closed by the handle's `close()` or destruction. Throws boost::system::system_error\n"
        << "  /// for a bad request or period.\n"
        << "  ::tether::rpc::Stream " << method.name << "(const " << request
        << "& request, std::chrono::milliseconds period,\n"
        << "      std::function<void(const ::tether::rpc::error_code& error, const " << reply
        << "& message)> handler) {\n"
        << "    return client_.open_stream_as<" << reply << ">(" << quoted
        << ", request, period, std::move(handler));\n"
        << "  }\n";
      continue;
    }
    h << "  /// Blocking: throws tether::rpc::CallError for the device's error answer (its code and text),\n"
      << "  /// boost::system::system_error otherwise.\n"
      << "  " << reply << " " << method.name << "(const " << request << "& request) {\n"
      << "    return client_.call_as<" << reply << ">(" << quoted << ", request);\n"
      << "  }\n"
      << "  /// " << method.name << ", blocking; failures in `error` (the reply is then empty).\n"
      << "  " << reply << " " << method.name << "(const " << request
      << "& request, ::tether::rpc::error_code& error) {\n"
      << "    return client_.call_as<" << reply << ">(" << quoted << ", request, error);\n"
      << "  }\n"
      << "  /// " << method.name << " for any asio completion token: completes `void(error_code, " << reply
      << ")`\n"
      << "  /// (an empty reply on failure; the device's code and text: `dynamic().async_call`).\n"
      << "  template <typename Token>\n"
      << "  auto async_" << method.name << "(const " << request << "& request, Token&& token) {\n"
      << "    return client_.async_call_as<" << reply << ">(" << quoted
      << ", request, std::forward<Token>(token));\n"
      << "  }\n";
  }
  h << "\n"
    << "  /// Blocks until the device answered with this schema; throws boost::system::system_error (naming both\n"
    << "  /// hashes when the device has another schema).\n"
    << "  void wait_ready() { client_.wait_ready(); }\n"
    << "  /// wait_ready; failures in `error`.\n"
    << "  void wait_ready(::tether::rpc::error_code& error) { client_.wait_ready(error); }\n"
    << "  /// wait_ready for any completion token: `void(error_code, std::uint32_t session_id)`.\n"
    << "  template <typename Token>\n"
    << "  auto async_wait_ready(Token&& token) {\n"
    << "    return client_.async_wait_ready(std::forward<Token>(token));\n"
    << "  }\n"
    << "  /// Diagnostics. Any thread.\n"
    << "  ::tether::rpc::Counters counters() const { return client_.counters(); }\n"
    << "  /// The session as the client knows it. Any thread.\n"
    << "  ::tether::rpc::SessionStatus session() const { return client_.session(); }\n"
    << "  /// Completes every pending call with operation_aborted and closes the stream. Idempotent, any thread.\n"
    << "  void close() { client_.close(); }\n"
    << "  /// False after close().\n"
    << "  bool is_open() const { return client_.is_open(); }\n"
    << "  /// The stream's executor: completion handlers without an executor of their own run on it.\n"
    << "  ::boost::asio::any_io_executor get_executor() const { return client_.get_executor(); }\n"
    << "  /// The dynamic client underneath (events, JSON calls, `CallResult`s with the device's error).\n"
    << "  ::tether::rpc::Client& dynamic() { return client_; }\n"
    << "  /// The dynamic client underneath.\n"
    << "  const ::tether::rpc::Client& dynamic() const { return client_; }\n\n"
    << " private:\n"
    << "  ::tether::rpc::Client client_;\n"
    << "};\n";
}

void write_client_definitions(std::ostringstream& cpp, const Schema& schema) {
  const pb::ServiceDescriptor& service = schema.service();
  const std::string name = service.name() + "Client";
  const pb::FileDescriptor& file = *service.file();
  cpp << "const ::google::protobuf::ServiceDescriptor& " << name << "::descriptor() {\n";
  if (file.message_type_count() > 0) {
    // Reached through a class of the same file: its use links protoc's code of the file into the program.
    cpp << "  const ::google::protobuf::ServiceDescriptor* service =\n"
        << "      " << cpp_class_name(*file.message_type(0)) << "::descriptor()->file()->FindServiceByName(\""
        << service.name() << "\");\n";
  } else {
    // No class of the file to reach it through: its descriptor table, named here, makes the linker take
    // protoc's code of the file (and its registration in the pool) from a static library.
    cpp << "  ::google::protobuf::internal::AssignDescriptors(&descriptor_table_" << protoc_file_identifier(file.name())
        << ");\n"
        << "  const ::google::protobuf::ServiceDescriptor* service =\n"
        << "      ::google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(\"" << service.full_name()
        << "\");\n";
  }
  cpp << "  if (service == nullptr) {\n"
      << "    throw ::tether::rpc::SchemaError(\"" << service.full_name()
      << ": protoc's code of " << file.name() << " is not linked into the program\");\n"
      << "  }\n"
      << "  return *service;\n"
      << "}\n\n"
      << "namespace {\n"
      << "::tether::rpc::Schema " << service.name() << "_schema() {\n"
      << "  ::tether::rpc::Schema schema(" << name << "::descriptor());\n"
      << "  if (schema.hash() != " << name << "::kSchemaHash) {\n"
      << "    throw ::tether::rpc::SchemaError(\"" << service.full_name()
      << ": protoc's classes in the program come from another version of " << file.name()
      << " (their hash \" + ::tether::rpc::format_hash(schema.hash()) + \", this client's \" +\n"
      << "        ::tether::rpc::format_hash(" << name << "::kSchemaHash) + \")\");\n"
      << "  }\n"
      << "  return schema;\n"
      << "}\n"
      << "}  // namespace\n\n"
      << name << "::" << name << "(std::shared_ptr<::tether::transports::ByteStream> stream,\n"
      << "    const ::tether::rpc::Options& options, ::tether::rpc::Client::EventHandler handler)\n"
      << "    : client_(std::move(stream), " << service.name()
      << "_schema(), options, std::move(handler)) {}\n";
}

}  // namespace

std::string cpp_class_name(const pb::Descriptor& type) {
  std::string name = type.name();
  for (const pb::Descriptor* outer = type.containing_type(); outer != nullptr; outer = outer->containing_type()) {
    name = outer->name() + "_" + name;
  }
  const std::string space = cpp_namespace(type.file()->package());
  return "::" + (space.empty() ? "" : space + "::") + name;
}

ClientCode client_code(const std::vector<Schema>& schemas, std::string_view stem_view) {
  const std::string stem(stem_view);
  const std::string origin = "Generated by tether-rpc-cpp (tether_generate_rpc) from " + stem + ".proto: do not edit.";
  std::ostringstream h;
  h << "// " << origin << "\n"
    << "/// @file " << stem << ".tether.hpp\n"
    << "/// The typed clients of " << stem << ".proto's services: each method a member taking and returning\n"
    << "/// protoc's classes (" << stem << ".pb.h), on a tether::rpc::Client whose schema is compiled in (no\n"
    << "/// .proto is read at run time).\n"
    << "#pragma once\n\n"
    << "#include <chrono>\n#include <cstdint>\n#include <functional>\n#include <memory>\n#include <utility>\n\n"
    << "#include \"" << stem << ".pb.h\"\n"
    << "#include \"tether/rpc/client.hpp\"\n";
  std::ostringstream cpp;
  cpp << "// " << origin << "\n"
      << "#include \"" << stem << ".tether.hpp\"\n\n"
      << "#include <google/protobuf/descriptor.h>\n\n"
      << "#include <string>\n";
  for (const Schema& schema : schemas) {
    const std::string space = cpp_namespace(schema.service().file()->package());
    const std::string open = space.empty() ? "" : "namespace " + space + " {\n\n";
    const std::string close = space.empty() ? "" : "\n}  // namespace " + space + "\n";
    h << "\n" << open;
    write_client_class(h, schema);
    h << close;
    cpp << "\n" << open;
    write_client_definitions(cpp, schema);
    cpp << close;
  }
  return ClientCode{h.str(), cpp.str()};
}

std::vector<std::filesystem::path> write_client_code(const std::filesystem::path& proto, const SchemaOptions& options,
                                                     const std::filesystem::path& directory) {
  const std::string stem = proto.stem().string();
  const ClientCode code = client_code(Schema::load_all(proto, options), stem);
  return write_generated_files(
      directory, {{stem + ".tether.hpp", &code.header}, {stem + ".tether.cpp", &code.source}});
}

}  // namespace tether::rpc
