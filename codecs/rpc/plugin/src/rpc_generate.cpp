// `tether generate SCHEMA.proto --out DIR [--service NAME] [--name NAME] [--force] [-I DIR]...`: a user's schema becomes an
// Arduino library, DIR/NAME/ (generator.hpp's write_arduino_library). The kit it copies from is found as
// the firmware images are: $TETHER_RPC_ARDUINO_DIR, else installed beside the program
// (bin/../share/tether/rpc-arduino), else the build tree's; nanopb's generator is $TETHER_NANOPB_GENERATOR,
// else the one the build found, else nanopb_generator.py / nanopb_generator on PATH.
//
// Output contract: stdout: the library's folder, one line; stderr: why it failed. Exit status: 0 written;
// 2 a usage error, a schema that does not read, a bad name, a folder in the way, a missing kit or nanopb.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "tether/rpc/generator.hpp"
#include "tether/rpc/plugin.hpp"

#if !defined(TETHER_RPC_ARDUINO_KIT_DIR) || !defined(TETHER_RPC_ARDUINO_INSTALLED_KIT_DIR)
#error "TETHER_RPC_ARDUINO_KIT_DIR must name the build's kit, TETHER_RPC_ARDUINO_INSTALLED_KIT_DIR the installed one"
#endif

namespace tether::cli {

/// `tether generate` (this plugin's subcommands(), rpc_call.cpp).
int run_rpc_generate(int argc, char** argv);

namespace {

namespace fs = std::filesystem;

const CommandText& rpc_generate_text() {
  static const CommandText text(
      "generate",
      "usage: tether generate SCHEMA.proto --out DIR [--service NAME] [--name NAME] [--force] [-I DIR]...\n"
      "\n"
      "Writes an Arduino library (1.5 format) that serves SCHEMA's service over the rpc codec: DIR/NAME/ with\n"
      "library.properties and src/NAME.h, the sketch's include. The sketch defines one handler per method,\n"
      "<Service>_<Method>, taking the request's nanopb struct and filling the reply's (for a stream: the next\n"
      "message, once per period while the host keeps it open), returning tether::rpc::Status::ok() or\n"
      "tether::rpc::Status::error(code, \"text\"); a missing handler is a link error naming it:\n"
      "  #include <ArmRpc.h>\n"
      "  tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {...}\n"
      "  ArmRpc device(Serial);\n"
      "  void setup() { Serial.begin(115200); device.begin(); }\n"
      "  void loop() { device.poll(); }\n"
      "nanopb's bounds of strings, bytes and repeated fields come from SCHEMA's .options file beside it (or\n"
      "nanopb's field options); every request must be at most 64 bytes encoded. Refused before anything is\n"
      "written: a double field (the AVR's double is 32-bit: use float), a message that contains itself, two\n"
      "names nanopb's C code would merge (a.B_C and a.B.C), a file whose nanopb code takes a kit file's name\n"
      "(tether_rpc.proto), a type named like the library's class.\n"
      "\n"
      "  --out DIR       the folder the library goes in (an Arduino libraries folder: ~/Arduino/libraries)\n"
      "  --service NAME  the service to serve when SCHEMA has more than one (default: its only service)\n"
      "  --name NAME     the library's and its class's name, a C++ identifier (default: the service's name\n"
      "                  and Rpc: ArmRpc)\n"
      "  --force         replace DIR/NAME when `tether generate` wrote it before (its GENERATED.txt); without\n"
      "                  it an existing non-empty DIR/NAME is refused, and a folder it did not write never\n"
      "                  replaced\n"
      "  -I DIR          a folder the schema's imports are found in (more than one: each in turn)\n"
      "\n"
      "Needs nanopb's generator (Debian: nanopb; $TETHER_NANOPB_GENERATOR names another) and the kit installed\n"
      "with tether (share/tether/rpc-arduino; $TETHER_RPC_ARDUINO_DIR names another).\n"
      "\n"
      "Prints the library's folder. Exit status: 0 written; 2 a schema that does not read, a bad name, a folder\n"
      "in the way, nanopb's generator missing or failing, usage errors.\n");
  return text;
}

// The kit `tether generate` copies from (see the file's overview).
fs::path kit_dir() {
  if (const char* dir = std::getenv("TETHER_RPC_ARDUINO_DIR"); dir != nullptr && *dir != '\0') return dir;
  std::error_code error;
  const auto self = fs::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto installed = (self.parent_path() / TETHER_RPC_ARDUINO_INSTALLED_KIT_DIR).lexically_normal();
    if (fs::is_directory(installed, error)) return installed;
  }
  return TETHER_RPC_ARDUINO_KIT_DIR;
}

// A program named `name` on PATH, or nothing.
std::optional<fs::path> on_path(std::string_view name) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return std::nullopt;
  std::string_view rest = path;
  while (!rest.empty()) {
    const std::size_t colon = rest.find(':');
    const std::string_view dir = rest.substr(0, colon);
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / name;
    if (access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

// nanopb's generator (see the file's overview), or nothing.
std::optional<fs::path> nanopb_generator() {
  if (const char* program = std::getenv("TETHER_NANOPB_GENERATOR"); program != nullptr && *program != '\0') {
    return fs::path(program);
  }
#ifdef TETHER_BUILD_NANOPB_GENERATOR
  if (access(TETHER_BUILD_NANOPB_GENERATOR, X_OK) == 0) return fs::path(TETHER_BUILD_NANOPB_GENERATOR);
#endif
  for (const char* name : {"nanopb_generator.py", "nanopb_generator"}) {
    if (auto found = on_path(name)) return found;
  }
  return std::nullopt;
}

}  // namespace

int run_rpc_generate(int argc, char** argv) {
  const CommandText& text = rpc_generate_text();
  std::string schema_path;
  std::optional<std::string> out;
  rpc::ArduinoLibraryOptions options;
  std::string service;
  const auto value_of = [&](int& i) -> std::optional<std::string> {
    if (i + 1 >= argc) return std::nullopt;
    return std::string(argv[++i]);
  };
  const auto status = parse_arguments(argc, argv, text, [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--out" || argument == "--name" || argument == "--service" || argument == "-I") {
      const auto value = value_of(i);
      if (!value || value->empty()) return text.usage_error(std::string(argument) + " needs a value");
      if (argument == "--out") {
        out = *value;
      } else if (argument == "--name") {
        options.name = *value;
      } else if (argument == "--service") {
        service = *value;
      } else {
        options.import_paths.emplace_back(*value);
      }
      return std::nullopt;
    }
    if (argument == "--force") {
      options.force = true;
      return std::nullopt;
    }
    if (argument.starts_with("-") || !schema_path.empty()) return text.unexpected_argument(argument);
    schema_path = argument;
    return std::nullopt;
  });
  if (status) return *status;
  if (schema_path.empty()) return text.usage_error("no schema: give the .proto file of the service");
  if (!out) return text.usage_error("no --out: give the folder the library goes in");

  try {
    rpc::SchemaOptions schema_options;
    schema_options.import_paths = options.import_paths;
    schema_options.service = service;
    const rpc::Schema schema = rpc::load_schema_to_serve(schema_path, schema_options, "--service");
    const auto generator = nanopb_generator();
    if (!generator) {
      return text.fail("nanopb's generator is not found (Debian: apt install nanopb; or set TETHER_NANOPB_GENERATOR)");
    }
    options.nanopb_generator = *generator;
    options.kit = kit_dir();
    const fs::path written = rpc::write_arduino_library(schema, *out, options);
    std::printf("%s\n", written.string().c_str());
  } catch (const rpc::SchemaError& e) {
    return text.fail(e.what());
  } catch (const rpc::GenerateError& e) {
    return text.fail(e.what());
  } catch (const std::exception& e) {
    return text.fail(e.what());
  }
  return 0;
}

}  // namespace tether::cli
