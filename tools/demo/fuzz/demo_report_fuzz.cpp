// Fuzz target of the demo report's text: a report whose texts and figures come from random bytes (device
// names and first errors can quote what a device sent: any bytes; figures can be any value, NaN included)
// rendered as the table (`tether demo`) and as JSON (`tether demo --json`).
// Invariants: nothing throws, no sanitizer finding, one table column and one JSON entry per device.
// Input: the run's figures, then per device its figures and texts (FuzzedDataProvider; texts up to 64 bytes).
#include <fuzzer/FuzzedDataProvider.h>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>

#include "tether/demo/rover_demo.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether::demo;

// Any double, NaN and infinities included (ConsumeFloatingPoint gives finite values only).
double any_double(FuzzedDataProvider& input) { return std::bit_cast<double>(input.ConsumeIntegral<std::uint64_t>()); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider input(data, size);
  DemoReport report;
  report.rover = input.ConsumeRandomLengthString(64);
  report.iterations = input.ConsumeIntegral<std::uint16_t>();
  report.bit_error_rate = any_double(input);
  report.reset_halfway = (input.ConsumeIntegral<std::uint8_t>() & 1) != 0;
  report.wall_seconds = any_double(input);
  while (input.remaining_bytes() != 0 && report.devices.size() < 4) {
    DeviceReport device;
    const auto flags = input.ConsumeIntegral<std::uint8_t>();
    device.confirmed = (flags & 1) != 0;
    device.operations = input.ConsumeIntegral<std::uint32_t>();
    device.successes = input.ConsumeIntegral<std::uint32_t>();
    device.failures = input.ConsumeIntegral<std::uint32_t>();
    device.wrong = input.ConsumeIntegral<std::uint32_t>();
    device.bytes_to_device = input.ConsumeIntegral<std::uint64_t>();
    device.bytes_from_device = input.ConsumeIntegral<std::uint64_t>();
    device.bits_flipped = input.ConsumeIntegral<std::uint64_t>();
    device.latency_p50_ms = any_double(input);
    device.latency_p99_ms = any_double(input);
    device.latency_max_ms = any_double(input);
    device.retries = input.ConsumeIntegral<std::uint32_t>();
    device.stale = input.ConsumeIntegral<std::uint32_t>();
    device.crc_errors = input.ConsumeIntegral<std::uint32_t>();
    device.framing_errors = input.ConsumeIntegral<std::uint32_t>();
    device.resyncs = input.ConsumeIntegral<std::uint32_t>();
    device.resets_injected = input.ConsumeIntegral<std::uint32_t>();
    if ((flags & 2) != 0) device.resets_detected = input.ConsumeIntegral<std::uint32_t>();
    if ((flags & 4) != 0) device.recovery_ms = any_double(input);
    if ((flags & 8) != 0) device.pins_match = (flags & 16) != 0;
    device.device = input.ConsumeRandomLengthString(64);
    device.codec = input.ConsumeRandomLengthString(64);
    device.transport = input.ConsumeRandomLengthString(64);
    device.operation = input.ConsumeRandomLengthString(64);
    device.pins_detail = input.ConsumeRandomLengthString(64);
    device.first_error = input.ConsumeRandomLengthString(64);
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
