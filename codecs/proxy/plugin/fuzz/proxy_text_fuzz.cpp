// Fuzz target of what `tether monitor` and `tether shell` make of what a proxy device says: frames through the
// monitor's decoder (either schema, either direction, with keepalive pings), every client event as a shell line
// (device texts, numbers, compat messages parsed from device bytes), each rendered as the text line and the JSON
// line. Input and invariants: tools/tether/text_fuzzing.hpp (byte 0, bit 1: compat mode).
#include <fuzzer/FuzzedDataProvider.h>
#include <google/protobuf/stubs/logging.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "proxy_text.hpp"
#include "tether/proxy/plugin.hpp"
#include "text_fuzzing.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);  // no "invalid UTF-8" log line per generated input
    return true;
  }();
  static_cast<void>(quiet);
  const std::uint8_t selector = data[0];
  if (fuzzes_monitor(selector)) {
    devices::DeviceConfig config;
    const bool compat = (selector & 0x02) != 0;
    config.codec = compat ? proxy::kCompatCodec : proxy::kCodec;
    proxy::DeviceOptions options;
    options.client.mode = compat ? proxy::Mode::compat : proxy::Mode::primary;
    config.options = options;
    check_monitor_decoding(config, data, size);
    return 0;
  }
  FuzzedDataProvider input(data + 1, size - 1);
  check_shell_line("event", proxy_event_line(proxy_event(input.ConsumeIntegral<std::uint8_t>(), input)));
  return 0;
}
