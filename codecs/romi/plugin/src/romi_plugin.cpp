// The Romi codec's plugin (plugin.hpp): its options in a configuration and its client on a device's stream.
#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <string>
#include <utility>
#include <vector>

#include "tether/devices/json_reader.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/encoder.hpp"
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

namespace {

// One frame decoded as a Romi decoder sees it (either direction: the host's capacity bounds both).
struct Decoded {
  bool complete = false;     // a whole frame, its CRC right
  Frame frame;               // what was parsed (after an error too)
  std::string payload;       // a copy of frame.payload
  Error error = Error::no_error;
};

Decoded decode(std::span<const std::uint8_t> bytes) {
  LinkCounters counters;
  Decoder<kHostDecoderCapacity> decoder(counters);
  Decoded result;
  for (const std::uint8_t byte : bytes) {
    const DecodeStatus status = decoder.feed(byte);
    if (status == DecodeStatus::more) continue;
    result.frame = decoder.frame();
    result.payload.assign(reinterpret_cast<const char*>(result.frame.payload.data()), result.frame.payload.size());
    result.frame.payload = ByteView();
    result.complete = status == DecodeStatus::frame;
    if (!result.complete) result.error = decoder.error();
    return result;
  }
  return result;  // no `\n`: the framing cut it short
}

std::vector<std::uint8_t> response(char opcode, std::string_view body, std::uint8_t id) {
  std::vector<std::uint8_t> frame(body.size() + kResponseOverhead + 16);
  const Result<std::size_t> written = encode_response(
      opcode, ByteView::from_chars(body.data(), body.size()), id, MutableByteView(frame.data(), frame.size()));
  frame.resize(written.ok() ? written.value() : 0);
  return frame;
}

// Playing a recorded Romi device: a request is its payload (`a[1]`; the id and CRC are the host's), an
// answer goes out with the id of the live request its recorded request matched and the CRC-8 over it.
class RomiReplayer final : public transports::CaptureReplayer {
 public:
  transports::ReplayRequest classify(std::span<const std::uint8_t> frame) override {
    const Decoded decoded = decode(frame);
    if (!decoded.complete || decoded.frame.log) return {};
    return {transports::ReplayRequest::Kind::request,
            decoded.frame.manual ? decoded.payload + " (manual)" : decoded.payload};
  }

  void matched(std::span<const std::uint8_t> recorded, std::span<const std::uint8_t> live) override {
    const Decoded was = decode(recorded);
    const Decoded now = decode(live);
    // A manual request's answer carries id 00, both recorded and live.
    ids_[was.frame.has_id ? was.frame.id : 0] = now.frame.has_id ? now.frame.id : 0;
  }

  std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) override {
    const std::vector<std::uint8_t> same(recorded.begin(), recorded.end());
    const Decoded decoded = decode(recorded);
    if (!decoded.complete || decoded.frame.log || decoded.frame.manual || !decoded.frame.has_id) return same;
    const auto live = ids_.find(decoded.frame.id);
    if (live == ids_.end()) return std::nullopt;  // the answer to a request the live host did not send
    if (decoded.payload.empty()) return same;
    return response(decoded.payload[0], std::string_view(decoded.payload).substr(1), live->second);
  }

  // What Romi firmware answers: an envelope error with what it parsed of the frame (its opcode, its id or
  // 00), and -16 (unknown opcode) to a request it has no handler for: the recording has none for it.
  std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t> live) override {
    const Decoded decoded = decode(live);
    if (decoded.frame.log) return {};
    const Error error = decoded.complete ? Error::unknown_opcode : decoded.error;
    if (error == Error::no_error) return {};  // cut short: the firmware is still waiting for its end
    // Appended, not `"[" + std::to_string(...)`: g++ 12 at -O3 warns a bogus overlap (-Wrestrict) there.
    std::string body = "[";
    body += std::to_string(static_cast<int>(error));
    body += ']';
    return {response(decoded.frame.opcode, body, decoded.frame.has_id ? decoded.frame.id : 0)};
  }

 private:
  std::map<std::uint8_t, std::uint8_t> ids_;  // recorded request id -> the live request's
};

}  // namespace

std::unique_ptr<transports::CaptureReplayer> capture_replayer() { return std::make_unique<RomiReplayer>(); }

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
  row.capture_replay = [](const devices::DeviceConfig&) { return capture_replayer(); };
  return {row};
}

}  // namespace tether::romi
