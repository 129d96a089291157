// Fuzz target of the capture reader (pcapng.hpp). Invariants: no crash or sanitizer finding; the reader
// ends (an error or the end) within one block per 12 input bytes; every packet names an interface it has
// described; an error always comes with a message naming an offset inside the input.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "tether/testing/fuzz_target.hpp"
#include "tether/transports/pcapng.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace tether::transports;
  std::istringstream input(std::string(reinterpret_cast<const char*>(data), size));
  CaptureReader reader(input);
  CaptureRecord record;
  boost::system::error_code error;
  std::string message;
  std::size_t records = 0;
  while (reader.next(record, error, message)) {
    ++records;
    TETHER_FUZZ_CHECK(records <= size / 12 + 1);
    TETHER_FUZZ_CHECK(record.interface.has_value() != record.packet.has_value());
    if (record.packet) {
      TETHER_FUZZ_CHECK(record.packet->interface < reader.interfaces().size());
      TETHER_FUZZ_CHECK(record.packet->data.size() <= size);
    }
    TETHER_FUZZ_CHECK(reader.offset() <= size);
  }
  if (error) {
    TETHER_FUZZ_CHECK(message.rfind("offset ", 0) == 0);
    TETHER_FUZZ_CHECK(error.category() == capture_category());
  }
  return 0;
}
