// The Romi codec's plugin (plugin.hpp): its options in a configuration and its client on a device's stream.
#include <chrono>
#include <memory>
#include <string_view>
#include <string>
#include <utility>

#include "tether/devices/json_reader.hpp"
#include "tether/romi/limits.hpp"
#include "tether/romi/plugin.hpp"

namespace tether::romi {

namespace {

devices::CodecOptions parse(const devices::OptionsContext& context) {
  DeviceOptions options;
  const std::optional<devices::JsonObject> object = context.object();
  if (!object) return options;
  devices::read_call_timing(*object, options.timing);
  if (auto v = object->optional("retry_on_timeout")) options.timing.retry_on_timeout = devices::read_bool(*v);
  if (auto v = object->optional("first_id")) {
    options.first_id = static_cast<std::uint8_t>(devices::read_unsigned(*v, 0, 254));
  }
  return options;
}

void validate(const devices::CodecOptions& codec_options, const std::string& options_path) {
  const auto* options = codec_options.get_if<DeviceOptions>();
  if (options == nullptr) devices::fail_config(options_path, "codec romi needs romi::DeviceOptions");
  devices::check_call_timing(options_path, options->timing);
}

devices::DeviceClient open(std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
                           std::shared_ptr<client::LinkClock> clock) {
  const auto& options = device.options.get<DeviceOptions>();
  Options client_options;
  client_options.timing = options.timing;
  client_options.clock = std::move(clock);
  client_options.first_id(options.first_id ? *options.first_id : random_first_id());
  return std::make_shared<Client>(std::move(stream), client_options);
}

}  // namespace

transports::BootSignature boot_signature() {
  transports::BootSignature signature;
  signature.name = "probe #\\r\\n";
  signature.probe = "#\r\n";
  signature.probe_answered = [](std::string_view received) {
    const std::size_t start = received.find('#');
    return start != std::string_view::npos && received.find("\r\n", start) != std::string_view::npos;
  };
  // Past optiboot's 1 s window, and never faster than it: every byte optiboot receives restarts that
  // window (measured on the virtual Uno: probes every 100 ms from 1.0 s kept it alive until 2.1 s).
  signature.silence = std::chrono::milliseconds(1200);
  signature.probe_interval = std::chrono::milliseconds(1100);
  return signature;
}

// Captures: a frame is `#...\n` (the decoder's framing: `#` starts a frame anywhere, also inside one);
// bounded by the host decoder's capacity and the frame's overhead.
transports::CaptureFraming capture_framing(const devices::DeviceConfig&) {
  return [](bool) -> std::unique_ptr<transports::CaptureFramer> {
    return std::make_unique<transports::DelimitedFramer>(
        transports::DelimitedFraming::lines("#", kHostDecoderCapacity + kFrameOverhead));
  };
}

std::vector<devices::CodecRow> codec_rows() {
  devices::CodecRow row;
  row.codec = kCodec;
  row.name = "romi";
  row.client_name = "romi::Client";
  row.client_type = &typeid(Client);
  row.option_keys = {"attempt_timeout_ms", "call_budget_ms", "max_attempts", "retry_on_timeout", "first_id"};
  row.parse_options = parse;
  row.validate = validate;
  row.open = open;
  row.boot = boot_signature();
  row.capture_framing = capture_framing;
  return {row};
}

}  // namespace tether::romi
