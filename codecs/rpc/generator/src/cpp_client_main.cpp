// The typed C++ client generator (generator.hpp: client_code) as tether_generate_rpc runs it:
// `tether-rpc-cpp SCHEMA.proto --out DIR [-I DIR]...` writes DIR/<stem>.tether.hpp and .cpp. The -I
// directories are searched for imports after the schema's own (as protoc's -I). Exit status 2 with the
// reason on a bad schema or arguments.
#include <iostream>
#include <string>

#include "tether/rpc/generator.hpp"

namespace {
int usage() {
  std::cerr << "usage: tether-rpc-cpp SCHEMA.proto --out DIR [-I DIR]...\n";
  return 2;
}
}  // namespace

int main(int argc, char** argv) {
  std::string schema_path, out;
  tether::rpc::SchemaOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (arg == "-I" && i + 1 < argc) {
      options.import_paths.emplace_back(argv[++i]);
    } else if (arg.rfind("-I", 0) == 0 && arg.size() > 2) {
      options.import_paths.emplace_back(arg.substr(2));
    } else if (schema_path.empty() && arg.rfind("-", 0) != 0) {
      schema_path = arg;
    } else {
      return usage();
    }
  }
  if (schema_path.empty() || out.empty()) return usage();
  try {
    tether::rpc::write_client_code(schema_path, options, out);
  } catch (const std::exception& e) {
    std::cerr << "tether-rpc-cpp: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
