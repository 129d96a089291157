// Fuzz target of what `tether monitor` and `tether shell` make of what a proxy device says: frames through the monitor's decoder (either schema, either
// direction, with keepalive pings), every client event as a shell line (device texts, numbers, compat messages
// parsed from device bytes), each rendered as the text line and the JSON line.
// Input: byte 0 picks the path: bit 0 clear, the monitor's decoding (the other bits: the decoder's role; bit 1: compat mode),
// the rest being the byte stream, one millisecond per byte; bit 0 set, a shell line (bits 1..: which one), the
// rest filling its values (FuzzedDataProvider: numbers, then text).
// Invariants: nothing throws (an exception would end the monitor or the shell's I/O thread), no sanitizer
// finding, every record has a kind and every JSON line its type, the output a decoder asks to send stays
// bounded.
#include <fuzzer/FuzzedDataProvider.h>
#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "proxy_text.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

void render(std::string_view type, const ShellLine& line) {
  TETHER_FUZZ_CHECK(shell_output(type, line, false) == line.text);
  const std::string json = shell_output(type, line, true);
  TETHER_FUZZ_CHECK(json.rfind("{\"type\":", 0) == 0);
}

proxy::Event proxy_event(std::uint8_t which, FuzzedDataProvider& input) {
  namespace ev = proxy::events;
  switch (which % 12) {
    case 0: {
      ev::DeviceError error;
      error.level = input.ConsumeBool() ? proxy::ErrorLevel::fatal : proxy::ErrorLevel::warning;
      error.text = input.ConsumeRemainingBytesAsString();
      return error;
    }
    case 1:
      return ev::DeviceInfo{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeBool()};
    case 2:
      return ev::FailsafeTriggered{input.ConsumeIntegral<std::uint32_t>()};
    case 3: {
      ev::PinReport report;
      report.kind = static_cast<proxy::PinKind>(input.ConsumeIntegral<std::uint8_t>() % 3);
      report.pin = input.ConsumeIntegral<std::uint32_t>();
      report.value = input.ConsumeIntegral<std::int32_t>();
      report.failsafe = input.ConsumeBool();
      return report;
    }
    case 4: {
      ev::PinLost lost;
      lost.kind = static_cast<proxy::PinKind>(input.ConsumeIntegral<std::uint8_t>() % 3);
      lost.pin = input.ConsumeIntegral<std::uint32_t>();
      lost.silent_ms = input.ConsumeIntegral<Duration>();
      return lost;
    }
    case 5:
      return ev::SessionEstablished{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint16_t>(),
                                    input.ConsumeBool()};
    case 6:
      return ev::ResetDetected{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint32_t>()};
    case 7:
      return ev::CompatEvent{static_cast<RocketryProto::EventTypes>(input.ConsumeIntegral<std::int32_t>()),
                             input.ConsumeIntegral<std::int32_t>()};
    case 8:
      return ev::CompatError{static_cast<RocketryProto::ErrorTypes>(input.ConsumeIntegral<std::int32_t>()),
                             input.ConsumeIntegral<std::int32_t>()};
    case 9: {
      ev::CompatState state;
      const std::string payload = input.ConsumeRemainingBytesAsString();
      static_cast<void>(state.message.ParseFromString(payload));  // what parsed, as the client would keep it
      return state;
    }
    case 10: {
      ev::UndecodableMessage undecodable;
      undecodable.malformed = input.ConsumeBool();
      undecodable.payload = input.ConsumeRemainingBytesAsString();
      return undecodable;
    }
    default:
      return ev::LinkFailed{proxy::error_code(input.ConsumeIntegral<int>(), boost::system::generic_category())};
  }
}

// The monitor's decoding of `data` (one millisecond per byte) for `config` in the role byte 0 gives.
void decode(const devices::DeviceConfig& config, std::uint8_t selector, const uint8_t* data, size_t size) {
  DecoderRole role;
  role.direction = (selector & 0x04) != 0 ? Direction::host_to_device : Direction::device_to_host;
  role.ring_node = (selector & 0x08) == 0;
  role.keepalive = (selector & 0x80) != 0;
  const auto decoder = make_monitor_decoder(config, role, 0);
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
  // Keepalive pings: one per second of input.
  TETHER_FUZZ_CHECK(output <= 2 * size + 64 * (size / 1000 + 1));
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
  if ((selector & 0x01) == 0) {
    devices::DeviceConfig config;
    const bool compat = (selector & 0x02) != 0;
    config.codec = compat ? proxy::kCompatCodec : proxy::kCodec;
    proxy::DeviceOptions options;
    options.client.mode = compat ? proxy::Mode::compat : proxy::Mode::primary;
    config.options = options;
    decode(config, selector, data, size);
    return 0;
  }
  FuzzedDataProvider input(data + 1, size - 1);
  render("event", proxy_event_line(proxy_event(input.ConsumeIntegral<std::uint8_t>(), input)));
  return 0;
}
