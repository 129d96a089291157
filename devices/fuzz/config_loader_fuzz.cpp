// Fuzz target of the JSON configuration loader: the input is a rover configuration and, the same bytes, an
// EEPROM file of every codec whose boards take one (`tether flash --eeprom`: an `elcano-node` file).
// Invariants: bad input is a `ConfigError` (what the commands print), never another exception, a crash or a
// sanitizer finding; what parses also passes `validate` (parsing guarantees it), and an EEPROM file that
// parses is bytes for a flash page (parsing encodes them).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string_view>

#include "tether/devices/codecs.hpp"
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
  for (const CodecRow* row : codec_rows()) {
    if (!row->eeprom_file.parse) continue;
    EepromUpload upload;
    if (parses([&] { upload = row->eeprom_file.parse(text); })) TETHER_FUZZ_CHECK(!upload.bytes.empty());
  }
  return 0;
}
