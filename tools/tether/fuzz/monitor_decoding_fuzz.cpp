// Fuzz target of `tether monitor`'s decoding: random bytes through each codec's decoder (as the monitor and
// as each direction of `monitor --tap` run it), every record rendered as the text line and the JSON line.
// Invariants: nothing throws (an exception would end the monitor), no sanitizer finding, every record has
// a kind, the output a decoder asks to send stays bounded.
// Input: byte 0 picks the codec and role, the rest is the byte stream (one millisecond per byte).
#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "monitor_decoding.hpp"
#include "tether/elcano/plugin.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/romi/plugin.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

devices::DeviceConfig config_for(std::uint8_t selector) {
  devices::DeviceConfig config;
  switch (selector % 4) {
    case 0:
      config.codec = devices::Codec::romi;
      config.options = romi::DeviceOptions();
      break;
    case 1:
    case 2: {
      config.codec = selector % 4 == 1 ? devices::Codec::proxy : devices::Codec::proxy_compat;
      proxy::DeviceOptions options;
      options.client.mode = selector % 4 == 1 ? proxy::Mode::primary : proxy::Mode::compat;
      config.options = options;
      break;
    }
    default: {
      config.codec = devices::Codec::elcano;
      elcano::DeviceOptions options;
      options.generation = (selector & 0x40) != 0 ? elcano::Generation::d : elcano::Generation::b;
      options.capture = elcano::TypeSet::from_bits(static_cast<std::uint8_t>(selector >> 4));
      config.options = options;
      break;
    }
  }
  return config;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);  // no "invalid UTF-8" log line per generated input
    return true;
  }();
  static_cast<void>(quiet);
  const std::uint8_t selector = data[0];
  DecoderRole role;
  role.direction = (selector & 0x04) != 0 ? Direction::host_to_device : Direction::device_to_host;
  role.ring_node = (selector & 0x08) == 0;
  role.keepalive = (selector & 0x80) != 0;
  const auto decoder = make_monitor_decoder(config_for(selector), role, 0);
  TETHER_FUZZ_CHECK(decoder != nullptr);
  std::vector<MonitorRecord> records;
  std::size_t output = 0;
  for (size_t i = 1; i < size; ++i) {
    const auto now = static_cast<Millis>(i);
    decoder->feed(data[i], now, records);
    decoder->poll(now, records);
    output += decoder->output(now).size();
    for (const MonitorRecord& record : records) {
      TETHER_FUZZ_CHECK(!record.kind.empty());
      TETHER_FUZZ_CHECK(!record_text(record).empty());
      TETHER_FUZZ_CHECK(!dump(record_json(record)).empty());
    }
    records.clear();
  }
  // A ring node forwards at most what it received (plus keepalive pings: one per second of input).
  TETHER_FUZZ_CHECK(output <= 2 * size + 64 * (size / 1000 + 1));
  return 0;
}
