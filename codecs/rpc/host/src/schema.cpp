#include "tether/rpc/schema.hpp"

#include <google/protobuf/compiler/importer.h>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include <cstdio>
#include <set>
#include <system_error>

namespace tether::rpc {

namespace {

namespace pb = google::protobuf;

// The device's method table is indexed by a byte.
constexpr std::size_t kMaxMethods = 255;

// Option-definition files: they shape the generated code, not the wire.
bool shapes_wire(const std::string& file) { return file != "nanopb.proto" && file != "google/protobuf/descriptor.proto"; }

constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325u;
constexpr std::uint64_t kFnvPrime = 0x100000001b3u;

void hash_bytes(std::uint64_t& hash, const std::string& bytes) {
  for (const char c : bytes) {
    hash ^= static_cast<std::uint8_t>(c);
    hash *= kFnvPrime;
  }
}

// Custom options (nanopb's `(nanopb).max_size`, anybody's own) shape generated code, not the wire. They
// are unknown fields of the descriptor's option messages, or extensions when the program links the
// options' own generated classes (a typed client of a schema that imports nanopb.proto). Removed
// everywhere, recursively.
void strip_custom_options(pb::Message& message) {
  const pb::Reflection& reflection = *message.GetReflection();
  reflection.MutableUnknownFields(&message)->Clear();
  std::vector<const pb::FieldDescriptor*> fields;
  reflection.ListFields(message, &fields);
  for (const pb::FieldDescriptor* field : fields) {
    if (field->is_extension()) {
      reflection.ClearField(&message, field);
      continue;
    }
    if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    if (field->is_repeated()) {
      for (int i = 0; i < reflection.FieldSize(message, field); ++i) {
        strip_custom_options(*reflection.MutableRepeatedMessage(&message, field, i));
      }
    } else {
      pb::Message& inner = *reflection.MutableMessage(&message, field);
      strip_custom_options(inner);
      // Options that held only custom ones are no options at all (an empty message still has a tag).
      if (field->name() == "options" && inner.ByteSizeLong() == 0) reflection.ClearField(&message, field);
    }
  }
}

// Dependencies first, each once.
void hash_file(std::uint64_t& hash, const pb::FileDescriptor& file, std::set<const pb::FileDescriptor*>& done,
               bool schema) {
  if (!done.insert(&file).second) return;
  for (int i = 0; i < file.dependency_count(); ++i) hash_file(hash, *file.dependency(i), done, false);
  if (!shapes_wire(file.name())) return;
  pb::FileDescriptorProto proto;
  file.CopyTo(&proto);  // no source info, no json names: positions and comments do not count
  if (schema) proto.clear_name();  // renaming the schema file changes nothing on the wire
  strip_custom_options(proto);
  // Importing an option-definition file is not a change either (only what imports are dependencies).
  auto& imports = *proto.mutable_dependency();
  for (int i = imports.size() - 1; i >= 0; --i) {
    if (!shapes_wire(imports.Get(i))) imports.DeleteSubrange(i, 1);
  }
  proto.clear_public_dependency();
  proto.clear_weak_dependency();
  std::string bytes;
  proto.SerializeToString(&bytes);  // deterministic: a FileDescriptorProto has no maps
  // Length-prefixed, so that two files cannot hash like one.
  hash_bytes(hash, std::to_string(bytes.size()) + ':');
  hash_bytes(hash, bytes);
}

}  // namespace

namespace detail {

// protoc's format, with 1-based positions (the collector's are 0-based; -1 when the error has none).
class CollectSchemaErrors : public pb::compiler::MultiFileErrorCollector {
 public:
  void AddError(const std::string& filename, int line, int column, const std::string& message) override {
    if (!text.empty()) text += '\n';
    text += filename;
    if (line >= 0) text += ':' + std::to_string(line + 1) + ':' + std::to_string(column + 1);
    text += ": " + message;
  }
  std::string text;
};

}  // namespace detail

struct Schema::Impl {
  std::filesystem::path file;
  pb::compiler::DiskSourceTree tree;
  detail::CollectSchemaErrors errors;
  pb::compiler::Importer importer{&tree, &errors};
  const pb::DescriptorPool* pool = nullptr;  // the importer's, or the generated pool
  const pb::ServiceDescriptor* service = nullptr;
  std::vector<Method> methods;
  std::uint64_t hash = 0;
};

namespace {

// A service's methods in wire order and its hash.
struct ServiceTable {
  const pb::ServiceDescriptor* service = nullptr;
  std::vector<Method> methods;
  std::uint64_t hash = 0;
};

// What both ways of making a schema check (proto3, methods the codec carries), then the table. `where`
// prefixes the errors (`arm.proto: `).
ServiceTable check_service(const pb::ServiceDescriptor& service, const std::string& where) {
  ServiceTable table;
  if (service.file()->syntax() != pb::FileDescriptor::SYNTAX_PROTO3) {
    throw SchemaError(where + "a schema is proto3 (`syntax = \"proto3\";`)");
  }
  if (service.method_count() == 0) throw SchemaError(where + "service " + service.name() + " has no rpc");
  if (static_cast<std::size_t>(service.method_count()) > kMaxMethods) {
    throw SchemaError(where + "service " + service.name() + " has " + std::to_string(service.method_count()) +
                      " methods (at most " + std::to_string(kMaxMethods) + ")");
  }
  for (int i = 0; i < service.method_count(); ++i) {
    const pb::MethodDescriptor& m = *service.method(i);
    if (m.client_streaming()) {
      throw SchemaError(where + service.name() + "." + m.name() +
                        ": client streaming is not carried (a method is a call or a server stream)");
    }
    table.methods.push_back(Method{m.name(), static_cast<std::uint16_t>(i), m.input_type(), m.output_type(),
                                   m.server_streaming()});
  }
  table.service = &service;
  table.hash = schema_hash(service);
  return table;
}

}  // namespace

namespace {

// Reads `file` and its imports into `importer` (whose source tree is `tree`); throws SchemaError.
const pb::FileDescriptor* import_schema(const std::filesystem::path& file, const SchemaOptions& options,
                                        pb::compiler::DiskSourceTree& tree, pb::compiler::Importer& importer,
                                        const detail::CollectSchemaErrors& errors) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw SchemaError(file.string() + ": " + (std::filesystem::exists(file, ec) ? "not a file" : "no such file"));
  }
  const std::filesystem::path directory = std::filesystem::absolute(file, ec).parent_path();
  tree.MapPath("", directory.string());
  for (const auto& path : options.import_paths) tree.MapPath("", path.string());
#ifdef TETHER_PROTOBUF_INCLUDE_DIR
  tree.MapPath("", TETHER_PROTOBUF_INCLUDE_DIR);
#endif
#ifdef TETHER_NANOPB_PROTO_DIR
  tree.MapPath("", TETHER_NANOPB_PROTO_DIR);
#endif
  const pb::FileDescriptor* descriptor = importer.Import(file.filename().string());
  if (descriptor == nullptr) {
    throw SchemaError(errors.text.empty() ? file.string() + ": cannot be read" : errors.text);
  }
  return descriptor;
}

}  // namespace

std::vector<Schema> Schema::load_all(const std::filesystem::path& file, const SchemaOptions& options) {
  std::vector<std::string> names;
  {
    pb::compiler::DiskSourceTree tree;
    detail::CollectSchemaErrors errors;
    pb::compiler::Importer importer(&tree, &errors);
    const pb::FileDescriptor* descriptor = import_schema(file, options, tree, importer, errors);
    for (int i = 0; i < descriptor->service_count(); ++i) names.push_back(descriptor->service(i)->name());
  }
  std::vector<Schema> schemas;
  for (const std::string& name : names) {  // each with a pool of its own, as load() makes
    SchemaOptions one = options;
    one.service = name;
    schemas.push_back(load(file, one));
  }
  return schemas;
}

Schema Schema::load(const std::filesystem::path& file, const SchemaOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->file = file;
  const pb::FileDescriptor* descriptor = import_schema(file, options, impl->tree, impl->importer, impl->errors);
  const std::string where = file.string() + ": ";
  if (descriptor->syntax() != pb::FileDescriptor::SYNTAX_PROTO3) {
    throw SchemaError(where + "a schema is proto3 (`syntax = \"proto3\";`)");
  }
  const pb::ServiceDescriptor* service = nullptr;
  if (options.service.empty()) {
    if (descriptor->service_count() == 0) throw SchemaError(where + "no service: the methods are a service's rpcs");
    if (descriptor->service_count() > 1) {
      std::string names;
      for (int i = 0; i < descriptor->service_count(); ++i) {
        names += (i == 0 ? "" : ", ") + descriptor->service(i)->name();
      }
      throw SchemaError(where + "more than one service (" + names + "): name the one to serve");
    }
    service = descriptor->service(0);
  } else {
    service = descriptor->FindServiceByName(options.service);
    if (service == nullptr) throw SchemaError(where + "no service " + options.service);
  }
  impl->pool = impl->importer.pool();
  ServiceTable table = check_service(*service, where);
  impl->service = table.service;
  impl->methods = std::move(table.methods);
  impl->hash = table.hash;
  return Schema(std::move(impl));
}

Schema::Schema(const pb::ServiceDescriptor& service) : impl_(std::make_unique<Impl>()) {
  impl_->file = service.file()->name();
  impl_->pool = service.file()->pool();
  ServiceTable table = check_service(service, service.file()->name() + ": ");
  impl_->service = table.service;
  impl_->methods = std::move(table.methods);
  impl_->hash = table.hash;
}

Schema::Schema(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Schema::Schema(Schema&&) noexcept = default;
Schema& Schema::operator=(Schema&&) noexcept = default;
Schema::~Schema() = default;

const std::filesystem::path& Schema::file() const { return impl_->file; }
const pb::ServiceDescriptor& Schema::service() const { return *impl_->service; }
std::span<const Method> Schema::methods() const { return impl_->methods; }
const Method* Schema::find(std::string_view name) const {
  for (const Method& method : impl_->methods) {
    if (method.name == name) return &method;
  }
  return nullptr;
}
std::uint64_t Schema::hash() const { return impl_->hash; }
const pb::DescriptorPool& Schema::pool() const { return *impl_->pool; }
bool Schema::compiled_in() const { return impl_->pool == pb::DescriptorPool::generated_pool(); }

std::uint64_t schema_hash(const pb::ServiceDescriptor& service) {
  std::uint64_t hash = kFnvOffset;
  std::set<const pb::FileDescriptor*> done;
  hash_file(hash, *service.file(), done, true);
  hash_bytes(hash, "service:" + service.full_name());
  return hash;
}

std::string format_hash(std::uint64_t hash) {
  char text[19];
  std::snprintf(text, sizeof text, "0x%016llx", static_cast<unsigned long long>(hash));
  return text;
}

}  // namespace tether::rpc
