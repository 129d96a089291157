/// @file schema.hpp
/// A user's schema, read at run time: a proto3 file with one `service` whose methods the rpc codec carries.
///
/// Unary methods are calls with a reply; server-streaming methods are streams the device sends at a period
/// the host asks for. A method is named on the wire by its index in the service (declaration order, from
/// 0); both ends prove they were built from the same schema by its hash (`Schema::hash`), which the device
/// sends in its hello and the host compares at open.
///
/// The hash is FNV-1a 64 over the canonical serialization of the schema's `FileDescriptorProto` and of each
/// file it imports, dependencies first (no source positions, no comments: reformatting the file or editing
/// a comment keeps the hash; renaming, renumbering, retyping or reordering anything changes it). Left out,
/// because they change the device's code, not the wire: custom options (nanopb's `(nanopb).max_size`,
/// ...), the files that only define options (`nanopb.proto`, `google/protobuf/descriptor.proto`) and the
/// imports of them, and the schema file's own name. An import is named as in the schema's `import` line.
/// The service's full name comes last (a file with two services has a hash for each). The same schema
/// gives the same hash wherever and under whatever name it is read.
///
/// Errors are `SchemaError`s whose message names the file, line and column as protoc does
/// (`arm.proto:7:3: "int33" is not defined.`).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace google::protobuf {
class Descriptor;
class DescriptorPool;
class FileDescriptor;
class ServiceDescriptor;
}  // namespace google::protobuf

namespace tether::rpc {

/// A schema that cannot be used: unreadable, not valid protobuf, no service or more than one without a
/// choice, a method the codec cannot carry (client streaming), too many methods.
class SchemaError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One method of the service.
struct Method {
  std::string name;                                  ///< As declared: `MoveJoint`.
  std::uint16_t index = 0;                           ///< On the wire: its position in the service.
  const google::protobuf::Descriptor* input = nullptr;   ///< The request's type.
  const google::protobuf::Descriptor* output = nullptr;  ///< The reply's (or each stream message's) type.
  bool streaming = false;                            ///< Server streaming (`returns (stream T)`).
};

/// Where and how to read a schema.
struct SchemaOptions {
  /// Directories searched for the schema's imports, after the schema's own directory and before the
  /// protobuf and nanopb installations' (the well-known types, `nanopb.proto`).
  std::vector<std::filesystem::path> import_paths;
  /// The service to serve when the file has more than one (empty: the file's only service).
  std::string service;
};

/// A loaded schema. Move-only; the descriptors it hands out live as long as it does.
class Schema {
 public:
  /// Reads and checks `file` (and its imports). Throws SchemaError.
  static Schema load(const std::filesystem::path& file, const SchemaOptions& options = {});

  Schema(Schema&&) noexcept;
  Schema& operator=(Schema&&) noexcept;
  ~Schema();

  /// The schema file as given to load().
  const std::filesystem::path& file() const;
  /// The service carried.
  const google::protobuf::ServiceDescriptor& service() const;
  /// Its methods, in wire order (`methods()[i].index == i`).
  std::span<const Method> methods() const;
  /// The method called `name` (as declared), or nullptr.
  const Method* find(std::string_view name) const;
  /// The hash both ends compare (see the file's overview).
  std::uint64_t hash() const;
  /// The pool that holds every descriptor of the schema (for dynamic messages).
  const google::protobuf::DescriptorPool& pool() const;

 private:
  struct Impl;
  explicit Schema(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// The hash of `service`'s file with its imports, and of which service it is (see the file's overview);
/// what `Schema::hash` returns.
std::uint64_t schema_hash(const google::protobuf::ServiceDescriptor& service);

/// A hash as the tools print it: `0x` and 16 lower-case hex digits.
std::string format_hash(std::uint64_t hash);

}  // namespace tether::rpc
