// The build's own runner of the service-code generator (generator.hpp), for the project's images and
// tests: `tether-rpc-service SCHEMA.proto --out DIR [--name NAME]`. Exit status 2 with the reason on a bad
// schema or arguments.
#include <iostream>
#include <string>

#include "tether/rpc/generator.hpp"

int main(int argc, char** argv) {
  std::string schema_path, out, name;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "--out" || arg == "--name") && i + 1 < argc) {
      (arg == "--out" ? out : name) = argv[++i];
    } else if (schema_path.empty() && arg.rfind("--", 0) != 0) {
      schema_path = arg;
    } else {
      std::cerr << "usage: tether-rpc-service SCHEMA.proto --out DIR [--name NAME]\n";
      return 2;
    }
  }
  if (schema_path.empty() || out.empty()) {
    std::cerr << "usage: tether-rpc-service SCHEMA.proto --out DIR [--name NAME]\n";
    return 2;
  }
  try {
    const tether::rpc::Schema schema = tether::rpc::Schema::load(schema_path);
    tether::rpc::write_service_code(schema, name.empty() ? tether::rpc::default_library_name(schema) : name, out);
  } catch (const std::exception& e) {
    std::cerr << "tether-rpc-service: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
