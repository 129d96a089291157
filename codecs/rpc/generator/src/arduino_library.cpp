// The Arduino library `tether generate` writes (generator.hpp): the kit's sources, nanopb's code of the
// schema, the service code (write_service_code) and the library's own header and properties.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <google/protobuf/descriptor.h>

#include <cctype>
#include <cerrno>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <system_error>

#include "tether/rpc/generator.hpp"

#include "generated_files.hpp"

extern char** environ;

namespace tether::rpc {
namespace {

namespace fs = std::filesystem;
namespace pb = google::protobuf;

// The marker of a folder this generator wrote: `--force` replaces only such folders.
constexpr const char* kMarker = "GENERATED.txt";

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw GenerateError(path.string() + ": cannot be written");
}

// Runs `arguments` (no shell), its stdout sent to stderr (ours stays the command's); its exit status, or
// -1 when it could not start.
int run_program(const std::vector<std::string>& arguments) {
  std::vector<char*> argv;
  for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

// The folders the schema's imports are looked up in, in Schema::load's order.
std::vector<fs::path> import_dirs(const Schema& schema, const ArduinoLibraryOptions& options) {
  std::error_code error;
  std::vector<fs::path> dirs = {fs::absolute(schema.file(), error).parent_path()};
  for (const fs::path& dir : options.import_paths) dirs.push_back(fs::absolute(dir, error));
#ifdef TETHER_PROTOBUF_INCLUDE_DIR
  dirs.emplace_back(TETHER_PROTOBUF_INCLUDE_DIR);
#endif
#ifdef TETHER_NANOPB_PROTO_DIR
  dirs.emplace_back(TETHER_NANOPB_PROTO_DIR);
#endif
  return dirs;
}

// nanopb's code of the schema and of every import that carries code, into `src` (an import's code in its
// import path's folders: `common/geometry.pb.h`, as nanopb's own #include lines name it).
void run_nanopb(const Schema& schema, const ArduinoLibraryOptions& options, const fs::path& src) {
  std::vector<const pb::FileDescriptor*> files;
  collect_files(*schema.service().file(), files);
  const std::vector<fs::path> dirs = import_dirs(schema, options);
  std::vector<std::string> arguments = {options.nanopb_generator.string(), "-q", "-D", src.string()};
  for (const fs::path& dir : dirs) {
    arguments.push_back("-I");
    arguments.push_back(dir.string());
  }
  for (const pb::FileDescriptor* file : files) {
    if (!carries_code(file->name())) continue;
    // The file on disk that the import's name stands for: the first folder that has it, as protoc's.
    fs::path found;
    std::error_code error;
    for (const fs::path& dir : dirs) {
      if (fs::is_regular_file(dir / file->name(), error)) {
        found = dir / file->name();
        break;
      }
    }
    if (found.empty()) throw GenerateError(file->name() + ": not found for nanopb (give its folder with -I)");
    arguments.push_back(found.string());
  }
  const int status = run_program(arguments);
  if (status < 0) {
    throw GenerateError("nanopb's generator (" + options.nanopb_generator.string() +
                        ") could not be run (Debian: apt install nanopb; or set TETHER_NANOPB_GENERATOR)");
  }
  if (status != 0) {
    throw GenerateError("nanopb's generator failed on " + schema.file().string() + " (exit status " +
                        std::to_string(status) + "; its messages are above)");
  }
}

// Refuses a double anywhere in the files nanopb writes code of: avr-gcc's double is 32-bit, so nanopb's
// code of the file stops at its DOUBLE_MUST_BE_8_BYTES assertion. (nanopb's PB_CONVERT_DOUBLE_FLOAT converts
// in nanopb's runtime, which the device does not use for the schema's messages.)
void refuse_doubles(const Schema& schema) {
  const auto check = [](const auto& self, const pb::Descriptor& type) -> void {
    for (int i = 0; i < type.field_count(); ++i) {
      const pb::FieldDescriptor& field = *type.field(i);
      if (field.type() != pb::FieldDescriptor::TYPE_DOUBLE) continue;
      throw SchemaError(field.file()->name() + ": " + field.full_name() +
                        " is a double: use float (a double on the AVR is 32-bit, and nanopb's code of a double "
                        "does not build there)");
    }
    for (int i = 0; i < type.nested_type_count(); ++i) self(self, *type.nested_type(i));
  };
  std::vector<const pb::FileDescriptor*> files;
  collect_files(*schema.service().file(), files);
  for (const pb::FileDescriptor* file : files) {
    if (!carries_code(file->name())) continue;
    for (int i = 0; i < file->message_type_count(); ++i) check(check, *file->message_type(i));
  }
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// Refuses a schema file (or an import) whose nanopb code would take the name of one of the kit's files
// (`tether_rpc.proto` -> `tether_rpc.pb.h`, the envelope's): compared without case, as the file systems of
// macOS and Windows do.
void refuse_kit_file_names(const Schema& schema, const fs::path& kit_src) {
  std::set<std::string> kit_files;
  std::error_code error;
  for (fs::recursive_directory_iterator it(kit_src, error), end; !error && it != end; it.increment(error)) {
    kit_files.insert(lower(it->path().lexically_relative(kit_src).generic_string()));
  }
  std::vector<const pb::FileDescriptor*> files;
  collect_files(*schema.service().file(), files);
  for (const pb::FileDescriptor* file : files) {
    if (!carries_code(file->name())) continue;
    const std::string stem = fs::path(file->name()).replace_extension().generic_string();
    for (const std::string& generated : {stem + ".pb.h", stem + ".pb.c"}) {
      if (kit_files.count(lower(generated)) == 0) continue;
      throw GenerateError(file->name() + ": nanopb's code of it would be " + generated +
                          ", which is the name of one of the kit's own files: rename " + file->name() +
                          (file == schema.service().file() ? "" : " and the import lines that name it"));
    }
  }
}

std::string library_properties(const Schema& schema, const std::string& name) {
  const std::string service = schema.service().full_name();
  std::ostringstream out;
  out << "name=" << name << "\n"
      << "version=1.0.0\n"
      << "author=tether generate\n"
      << "maintainer=tether generate\n"
      << "sentence=The " << service << " service of " << schema.file().filename().string()
      << " over Tether's rpc codec (COBS + CRC-16, exactly-once calls, streams).\n"
      << "paragraph=Generated by `tether generate`: define one handler per method (<Service>_<Method>), "
         "then "
      << name << " device(Serial); device.begin() in setup(), device.poll() in loop(). nanopb runtime included; "
         "needs the TetherCore library.\n"
      << "category=Communication\n"
      << "url=https://example.invalid/tether\n"
      << "architectures=avr\n"
      << "depends=TetherCore\n"  // the core and the Arduino glue, installed once for every Tether library
      << "includes=" << name << ".h\n";
  return out.str();
}

std::string marker_text(const Schema& schema, const std::string& name) {
  return "This Arduino library was generated by `tether generate` from " + schema.file().filename().string() +
         " (service " + schema.service().full_name() + ", schema hash " + format_hash(schema.hash()) +
         ").\nDo not edit it: generate it again (tether generate " + schema.file().filename().string() +
         " --out DIR --name " + name + " --force) after changing the schema.\n";
}

// A folder next to `target` that does not exist yet, for building the library in.
fs::path staging_folder(const fs::path& target) {
  std::random_device seed;
  std::mt19937 random(seed());
  for (int attempt = 0; attempt < 100; ++attempt) {
    // Appended piece by piece: g++ 12's -Wrestrict misfires on `"." + string` at -O2.
    std::string name = ".";
    name += target.filename().string();
    name += ".partial-";
    name += std::to_string(random() % 1000000);
    const fs::path candidate = target.parent_path() / name;
    std::error_code error;
    if (!fs::exists(candidate, error) && !error) return candidate;
  }
  throw GenerateError(target.parent_path().string() + ": no room for a staging folder");
}

// Removes the staging folder unless released (the library was moved into place).
class Staging {
 public:
  explicit Staging(fs::path path) : path_(std::move(path)) {}
  ~Staging() {
    std::error_code error;
    if (!path_.empty()) fs::remove_all(path_, error);
  }
  Staging(const Staging&) = delete;
  Staging& operator=(const Staging&) = delete;
  const fs::path& path() const { return path_; }
  void release() { path_.clear(); }

 private:
  fs::path path_;
};

}  // namespace

std::string arduino_library_header(const Schema& schema, std::string_view name_view) {
  const std::string name(name_view);
  const std::string service = name + "Service";
  const std::string full = schema.service().full_name();
  std::ostringstream h;
  h << "// Generated by `tether generate` from " << schema.file().filename().string() << " (service " << full
    << ", schema hash " << format_hash(schema.hash()) << "): do not edit.\n"
    << "/// @file " << name << ".h\n"
    << "/// " << full << " on an Arduino, over Tether's rpc codec. The sketch defines one handler per method,\n"
    << "/// declared in " << name << "_service.h (a missing one is a link error that names it):\n"
    << "///\n";
  for (const Method& method : schema.methods()) {
    h << "///     tether::rpc::Status " << handler_name(schema, method) << "(const " << nanopb_name(*method.input)
      << "& request, " << nanopb_name(*method.output) << (method.streaming ? "& next);" : "& reply);")
      << (method.streaming ? "  // once per period of an open stream" : "") << "\n";
  }
  h << "///\n"
    << "/// each returning tether::rpc::Status::ok() or tether::rpc::Status::error(code, \"text\"), and runs the\n"
    << "/// device from its loop:\n"
    << "///\n"
    << "///     " << name << " device(Serial);\n"
    << "///     void setup() { Serial.begin(115200); device.begin(); }\n"
    << "///     void loop() { device.poll(); }\n"
    << "#pragma once\n\n"
    << "#include <Arduino.h>\n\n"
    << "#include \"TetherRpcArduino.h\"\n"
    << "#include \"TetherSetArduinoMacrosAside.h\"\n"
    << "#include \"" << name << "_service.h\"\n"
    << "#include \"TetherRestoreArduinoMacros.h\"\n\n"
    << "/// " << full << " served on a Stream (`Serial`: the fast path); begin() after Serial.begin(), poll() from loop().\n"
    << "class " << name << " : public tether::arduino::RpcDevice<" << service << "> {\n"
    << " public:\n"
    << "  /// The device on a Stream, or on the core's HardwareSerial (`Serial`: the fast path).\n"
    << "  using tether::arduino::RpcDevice<" << service << ">::RpcDevice;\n"
    << "};\n";
  return h.str();
}

fs::path write_arduino_library(const Schema& schema, const fs::path& out, const ArduinoLibraryOptions& options) {
  const std::string name = options.name.empty() ? default_library_name(schema) : options.name;
  (void)service_code(schema, name, "");  // refuses a name that is not an identifier, before anything is written
  std::error_code error;
  const fs::path kit_src = options.kit / "src";
  if (!fs::is_regular_file(kit_src / "TetherRpcArduino.h", error)) {
    throw GenerateError("the Arduino kit is missing: " + options.kit.string() +
                        " has no src/TetherRpcArduino.h (set TETHER_RPC_ARDUINO_DIR to share/tether/rpc-arduino)");
  }
  for (const std::string& file : {name + ".h", name + "_service.h", name + "_service.cpp"}) {
    if (fs::exists(kit_src / file, error)) {
      throw GenerateError("library name \"" + name + "\" clashes with the kit's " + file + ": choose another --name");
    }
  }
  refuse_kit_file_names(schema, kit_src);
  refuse_doubles(schema);

  fs::create_directories(out, error);
  if (error || !fs::is_directory(out, error)) {
    throw GenerateError(out.string() + ": cannot be made a folder" + (error ? ": " + error.message() : ""));
  }
  const fs::path target = out / name;
  bool replace = false;
  if (fs::exists(target, error)) {
    const bool empty = fs::is_directory(target, error) && fs::is_empty(target, error);
    if (!empty) {
      if (!options.force) {
        throw GenerateError(target.string() + " exists and is not empty: give --force to replace a library " +
                            "generated before, or another --out or --name");
      }
      if (!fs::is_regular_file(target / kMarker, error)) {
        throw GenerateError(target.string() + " was not written by `tether generate` (no " + kMarker +
                            "): not replaced, even with --force");
      }
    }
    replace = true;
  }

  Staging staging(staging_folder(target));
  const fs::path src = staging.path() / "src";
  fs::create_directories(src, error);
  if (error) throw GenerateError(src.string() + ": " + error.message());
  fs::copy(kit_src, src, fs::copy_options::recursive, error);
  if (error) throw GenerateError("copying the kit " + kit_src.string() + ": " + error.message());
  run_nanopb(schema, options, src);
  try {
    write_service_code(schema, name, src);
  } catch (const SchemaError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw GenerateError(e.what());
  }
  write_text(src / (name + ".h"), arduino_library_header(schema, name));
  write_text(staging.path() / "library.properties", library_properties(schema, name));
  write_text(staging.path() / kMarker, marker_text(schema, name));

  if (replace) {
    fs::remove_all(target, error);
    if (error) throw GenerateError(target.string() + ": cannot be replaced: " + error.message());
  }
  fs::rename(staging.path(), target, error);
  if (error) throw GenerateError(target.string() + ": " + error.message());
  staging.release();
  return target;
}

}  // namespace tether::rpc
