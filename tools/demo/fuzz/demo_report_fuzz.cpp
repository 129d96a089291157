// Fuzz target of the demo report's text: a report whose texts and figures come from random bytes (device
// names and first errors can quote what a device sent: any bytes; figures can be any value, NaN included)
// rendered as the table (`tether demo`) and as JSON (`tether demo --json`).
// Invariants: nothing throws, no sanitizer finding, one table column and one JSON entry per device.
// Input: per device, its figures (little-endian) then its texts, each text up to a 0 byte.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "tether/demo/rover_demo.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether::demo;

// Takes values off the input, front to back; zeros and empty texts when it runs out.
class InputBytes {
 public:
  InputBytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return position_ >= size_; }

  template <typename Number>
  Number take() {
    unsigned char bytes[sizeof(Number)] = {};
    for (unsigned char& byte : bytes) byte = next();
    Number value;
    std::memcpy(&value, bytes, sizeof value);
    return value;
  }
  /// Bytes up to the next 0 (or the end), at most 64.
  std::string text() {
    std::string value;
    while (!empty() && data_[position_] != 0 && value.size() < 64) value += static_cast<char>(next());
    if (!empty()) ++position_;
    return value;
  }

 private:
  unsigned char next() { return position_ < size_ ? data_[position_++] : 0; }
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  InputBytes input(data, size);
  DemoReport report;
  report.rover = input.text();
  report.iterations = input.take<std::uint16_t>();
  report.bit_error_rate = input.take<double>();
  report.reset_halfway = (input.take<std::uint8_t>() & 1) != 0;
  report.wall_seconds = input.take<double>();
  while (!input.empty() && report.devices.size() < 4) {
    DeviceReport device;
    const auto flags = input.take<std::uint8_t>();
    device.confirmed = (flags & 1) != 0;
    device.operations = input.take<std::uint32_t>();
    device.successes = input.take<std::uint32_t>();
    device.failures = input.take<std::uint32_t>();
    device.wrong = input.take<std::uint32_t>();
    device.bytes_to_device = input.take<std::uint64_t>();
    device.bytes_from_device = input.take<std::uint64_t>();
    device.bits_flipped = input.take<std::uint64_t>();
    device.latency_p50_ms = input.take<double>();
    device.latency_p99_ms = input.take<double>();
    device.latency_max_ms = input.take<double>();
    device.retries = input.take<std::uint32_t>();
    device.stale = input.take<std::uint32_t>();
    device.crc_errors = input.take<std::uint32_t>();
    device.framing_errors = input.take<std::uint32_t>();
    device.resets_injected = input.take<std::uint32_t>();
    if ((flags & 2) != 0) device.resets_detected = input.take<std::uint32_t>();
    if ((flags & 4) != 0) device.recovery_ms = input.take<double>();
    if ((flags & 8) != 0) device.pins_match = (flags & 16) != 0;
    device.device = input.text();
    device.codec = input.text();
    device.transport = input.text();
    device.operation = input.text();
    device.pins_detail = input.text();
    device.first_error = input.text();
    report.devices.push_back(std::move(device));
  }
  const std::string table = format_table(report);
  TETHER_FUZZ_CHECK(!table.empty());
  const std::string json = format_json(report);
  const auto parsed = nlohmann::json::parse(json, nullptr, false);
  TETHER_FUZZ_CHECK(!parsed.is_discarded());
  TETHER_FUZZ_CHECK(parsed["devices"].size() == report.devices.size());
  return 0;
}
