// Fuzz target of the JSON configuration loader: the input is a rover configuration and, the same bytes,
// an `elcano-node` file (`tether flash --eeprom`). Invariants: bad input is a `ConfigError` (what the
// commands print), never another exception, a crash or a sanitizer finding; what parses also passes
// `validate` (parsing guarantees it) and a parsed node file encodes into a block.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string_view>

#include "tether/devices/config.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether::devices;

// Runs `parse`; true when it returned, false on a ConfigError; any other exception is a finding.
template <typename Parse>
bool parses(Parse&& parse) {
  try {
    parse();
    return true;
  } catch (const ConfigError& error) {
    TETHER_FUZZ_CHECK(error.what()[0] != '\0');
    return false;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "not a ConfigError: %s\n", error.what());
    TETHER_FUZZ_CHECK(false);
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  ParseOptions options;
  options.firmware_dir = "/nonexistent-firmware";
  RoverConfig config;
  if (parses([&] { config = parse_config(text, options); })) {
    TETHER_FUZZ_CHECK(!config.devices.empty());
    TETHER_FUZZ_CHECK(parses([&] { validate(config); }));
  }
  NodeFile node;
  if (parses([&] { node = parse_node_file(text); })) {
    TETHER_FUZZ_CHECK(parses([&] { encode_node_block(node.settings, node.generation, node.baud); }));
  }
  return 0;
}
