/// @file generator.hpp
/// What `tether generate` writes for a schema: the device's service (C++ for the AVR, on nanopb's structs)
/// and, around it, an Arduino library.
///
/// The service code is two files named after the library (`ArmRpc`): `ArmRpc_service.h` declares one
/// handler per method, `<Service>_<Method>`, taking the request's and the reply's nanopb structs
/// (`tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply);`; for a
/// stream, the next message), and `ArmRpcService`: the schema hash, the table sizes derived from nanopb's
/// bounds (`Limits`) and `service()`. `ArmRpc_service.cpp` holds the table and the thunks that call the
/// handlers, so a handler the application does not define is a link error that names it. The same two
/// files go into the Arduino library, the project's bare-metal images and the host tests.
///
/// The Arduino library (`write_arduino_library`, what `tether generate` runs) is a folder `<name>/` in
/// the Arduino 1.5 format: library.properties, `src/<name>.h` (the sketch's include: the class `<name>`
/// on the Arduino glue, TetherRpcArduino.h), the service code, nanopb's code of the schema (and of its
/// imports) made by nanopb's generator, and the kit's portable sources (the device runtime, Tether's core,
/// the envelope's nanopb code, the nanopb runtime) copied as they are.
///
/// For the host it writes typed C++ clients (`client_code`: `arm::ArmClient` in `arm.tether.hpp`), which
/// `tether_generate_rpc` builds with protoc's classes of the same file.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "tether/rpc/schema.hpp"

namespace google::protobuf {
class Descriptor;
}

namespace tether::rpc {

/// The C name nanopb gives a message: its full name with `.` as `_` (`arm.Outer.Inner` -> `arm_Outer_Inner`).
std::string nanopb_name(const google::protobuf::Descriptor& type);

/// Schema::load for a command whose option `option` (`--service`) fills `options.service`: a file with more
/// than one service and none chosen is refused with a message that says to choose one with `option NAME`.
/// Throws SchemaError.
Schema load_schema_to_serve(const std::filesystem::path& file, const SchemaOptions& options, std::string_view option);

/// The default library name: the service's name and `Rpc` (`Arm` -> `ArmRpc`).
std::string default_library_name(const Schema& schema);

/// A handler's name: `<Service>_<Method>`.
std::string handler_name(const Schema& schema, const Method& method);

/// The service code of `schema` for a library called `name` (a C++ identifier); `nanopb_header` is the
/// schema's nanopb header (`arm.pb.h`).
struct ServiceCode {
  std::string header;  ///< `<name>_service.h`
  std::string source;  ///< `<name>_service.cpp`
};
/// Throws SchemaError for a name that is not a C++ identifier and for what would not build: a message the
/// methods reach that contains itself (nanopb makes the field a callback), two types or enum values with one
/// C name in nanopb's code (`a.B_C` and `a.B.C`), a name starting `tether_rpc_` (the kit's), the library's
/// class, its `<name>Service` or a handler named like one of nanopb's types or macros (a package-less
/// `message ArmRpc` beside `service Arm`).
ServiceCode service_code(const Schema& schema, std::string_view name, std::string_view nanopb_header);

/// Writes `<name>_service.h` and `<name>_service.cpp` into `directory` (created); returns their paths.
/// Throws SchemaError for a name that is not a C++ identifier, std::runtime_error for a directory that
/// cannot be written.
std::vector<std::filesystem::path> write_service_code(const Schema& schema, std::string_view name,
                                                      const std::filesystem::path& directory);

/// What `write_arduino_library` needs besides the schema.
struct ArduinoLibraryOptions {
  std::string name;                        ///< the library's name (empty: `default_library_name`)
  std::filesystem::path kit;               ///< the kit folder (share/tether/rpc-arduino: its src/ is copied)
  std::filesystem::path nanopb_generator;  ///< nanopb's generator program (nanopb_generator.py)
  std::vector<std::filesystem::path> import_paths;  ///< where the schema's imports are found (as SchemaOptions')
  bool force = false;  ///< replace an existing library folder this function wrote before
};

/// A library that cannot be written: a folder in the way, a kit missing, nanopb's generator failing. The
/// message says why and what to do.
class GenerateError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The library's `src/<name>.h`: the class `<name>` serving the schema's service on the Arduino glue.
std::string arduino_library_header(const Schema& schema, std::string_view name);

/// Writes the Arduino library of `schema` as `out/<name>/` and returns its path. The folder is built
/// beside its final place and moved there once complete, so a failure leaves nothing half written. An
/// existing non-empty `out/<name>/` is refused unless `options.force` and it holds `GENERATED.txt` (the
/// marker this function writes): then it is replaced as a whole (the library is generated output; the
/// sketch lives elsewhere). Throws SchemaError for what `service_code` refuses and for a `double` field
/// (avr-gcc's double is 32-bit: use float), GenerateError otherwise (a schema file or import whose nanopb
/// code would take a kit file's name: `tether_rpc.proto`).
std::filesystem::path write_arduino_library(const Schema& schema, const std::filesystem::path& out,
                                            const ArduinoLibraryOptions& options);

/// The C++ class protoc makes for `type`, fully qualified (`arm.Description.Range` ->
/// `::arm::Description_Range`).
std::string cpp_class_name(const google::protobuf::Descriptor& type);

/// The host's typed clients of a .proto file (what `tether_generate_rpc` builds beside protoc's classes):
/// `<stem>.tether.hpp` declares one `<Service>Client` per service of the file, in its package's namespace
/// (`arm::ArmClient`), on a `tether::rpc::Client` of the compiled-in schema; `<stem>.tether.cpp` holds
/// what is not inline. `schemas` are the file's services (`Schema::load_all`; none: the two files only
/// include protoc's header), `stem` the file's name without `.proto`.
struct ClientCode {
  std::string header;  ///< `<stem>.tether.hpp`
  std::string source;  ///< `<stem>.tether.cpp`
};
/// Throws SchemaError for a method whose name is a C++ keyword or one of the client's own members (`close`,
/// `wait_ready`, `client_`, ...) or whose `async_` form is another method's name, and for a message, enum
/// or enum value of the package named like the class (`SensorClient` beside `service Sensor`).
ClientCode client_code(const std::vector<Schema>& schemas, std::string_view stem);

/// Writes `<stem>.tether.hpp` and `<stem>.tether.cpp` of `proto` (its services read with `options`) into
/// `directory` (created); returns their paths. Throws SchemaError, std::runtime_error as `write_service_code`.
std::vector<std::filesystem::path> write_client_code(const std::filesystem::path& proto, const SchemaOptions& options,
                                                     const std::filesystem::path& directory);

}  // namespace tether::rpc
