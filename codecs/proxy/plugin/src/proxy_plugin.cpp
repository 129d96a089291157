// The proxy codec's plugin (plugin.hpp): `proxy` and `proxy-compat` devices in a configuration, their
// clients, and opening's wait for the handshake and the inits.
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <string>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>

#include "tether/devices/json_reader.hpp"
#include "tether/proxy/boot_frame.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/plugin.hpp"

namespace tether::proxy {

namespace {

[[noreturn]] void fail_open(std::string path, std::string detail, error_code code) {
  throw devices::ConfigError(std::move(path), std::move(detail), code);
}

const char* kind_name(PinInit::Kind kind) { return kind == PinInit::Kind::servo ? "servo" : "digital"; }

PinInit parse_init(const devices::JsonNode& node) {
  const devices::JsonObject object(node);
  PinInit init;
  const devices::JsonNode kind = object.required("kind");
  init.kind = devices::read_choice(kind, "init kind", {"servo", "digital"}) == 0 ? PinInit::Kind::servo
                                                                                 : PinInit::Kind::digital;
  if (init.kind == PinInit::Kind::servo) {
    object.allow_only({"kind", "pin", "safe_position"},
                      {{"safe_state", "is for digital inits (servo: safe_position)"}});
  } else {
    object.allow_only({"kind", "pin", "safe_state"}, {{"safe_position", "is for servo inits (digital: safe_state)"}});
  }
  init.pin = static_cast<std::uint32_t>(devices::read_unsigned(object.required("pin"), 0, 255));
  if (init.kind == PinInit::Kind::servo) {
    init.safe_value = static_cast<std::int32_t>(devices::read_unsigned(object.required("safe_position"), 0, 180));
  } else {
    init.safe_value = devices::read_bool(object.required("safe_state")) ? 1 : 0;
  }
  return init;
}

DeviceOptions parse_proxy_options(const devices::JsonObject* object, devices::Codec codec,
                                  const devices::TransportConfig& transport) {
  DeviceOptions options;
  options.client = codec == kCodec ? Options::primary() : Options::compat();
  if (const auto* serial = std::get_if<devices::SerialTransport>(&transport))
    options.client.timing.baud = serial->options.baud;
  if (object == nullptr) return options;
  ProxyTiming& timing = options.client.timing;
  if (auto v = object->optional("baud"))
    timing.baud = static_cast<std::uint32_t>(devices::read_unsigned(*v, 1, 0xFFFFFFFFu));
  if (auto v = object->optional("bits_per_byte"))
    timing.bits_per_byte = static_cast<std::uint32_t>(devices::read_unsigned(*v, 1, 64));
  if (auto v = object->optional("processing_margin_ms")) timing.processing_margin = devices::read_ms(*v);
  if (auto v = object->optional("send_budget_ms")) timing.send_budget = devices::read_ms(*v, 1);
  if (auto v = object->optional("max_sends"))
    timing.max_sends = static_cast<std::uint8_t>(devices::read_unsigned(*v, 1, 255));
  if (auto v = object->optional("queue_timeout_ms")) timing.queue_timeout = devices::read_ms(*v, 1);
  if (auto v = object->optional("ping_period_ms")) timing.ping_period = devices::read_ms(*v);
  if (auto v = object->optional("reset_timeout_ms")) timing.session.reset_timeout = devices::read_ms(*v, 1);
  if (auto v = object->optional("stale_after_ms")) timing.stale_after = devices::read_ms(*v, 1);
  if (auto v = object->optional("replay_on_reset")) options.client.compat_replay_on_reset = devices::read_bool(*v);
  if (auto v = object->optional("open_timeout_ms"))
    options.open_timeout = std::chrono::milliseconds(devices::read_ms(*v, 1));
  if (auto v = object->optional("inits")) {
    if (!v->value.is_array()) v->expected("an array of inits");
    if (v->value.size() > kMaxInits) {
      devices::fail_config(
          v->path, "expected at most " + std::to_string(kMaxInits) + " inits, got " + std::to_string(v->value.size()));
    }
    devices::for_each_element(*v, [&](const devices::JsonNode& element, std::size_t i) {
      const PinInit init = parse_init(element);
      for (std::size_t j = 0; j < i; ++j) {
        const PinInit& earlier = options.inits[j];
        if (earlier.kind == init.kind && earlier.pin == init.pin) {
          devices::fail_config(element.path, std::string(kind_name(init.kind)) + " " + std::to_string(init.pin) +
                                                 " is already initialised by inits[" + std::to_string(j) + "]");
        }
      }
      options.inits.push_back(init);
    });
  }
  return options;
}

// --- proxy: inits and handshake ------------------------------------------------------------------------------

// What opening a proxy device waits for, filled in from the client's completions and events.
struct ProxyReadiness {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t inits_pending = 0;
  bool established = false;
  std::optional<std::size_t> failed_init;
  error_code init_error;
  error_code link_error;
};

std::string init_text(const PinInit& init) {
  return std::string(init.kind == PinInit::Kind::servo ? "servo " : "digital ") + std::to_string(init.pin);
}

devices::CodecOptions parse_proxy(const devices::OptionsContext& context) {
  const std::optional<devices::JsonObject> object = context.object();
  return parse_proxy_options(object ? &*object : nullptr, context.codec, *context.transport);
}

void validate_proxy(const devices::CodecOptions& codec_options, const std::string& options_path, devices::Codec codec) {
  const auto* options = codec_options.get_if<DeviceOptions>();
  if (options == nullptr)
    devices::fail_config(options_path,
                         "codec " + std::string(devices::to_string(codec)) + " needs proxy::DeviceOptions");
  const Mode mode = codec == kCodec ? Mode::primary : Mode::compat;
  if (options->client.mode != mode) {
    devices::fail_config(options_path,
                         "the client's mode does not match codec " + std::string(devices::to_string(codec)));
  }
  const ProxyTiming& timing = options->client.timing;
  if (timing.baud == 0) devices::fail_config(options_path + ".baud", "must be at least 1");
  if (timing.bits_per_byte == 0) devices::fail_config(options_path + ".bits_per_byte", "must be at least 1");
  if (timing.send_budget == 0) devices::fail_config(options_path + ".send_budget_ms", "must be at least 1");
  if (timing.max_sends == 0) devices::fail_config(options_path + ".max_sends", "must be at least 1");
  if (options->inits.size() > kMaxInits) devices::fail_config(options_path + ".inits", "too many inits");
  for (std::size_t k = 0; k < options->inits.size(); ++k) {
    const PinInit& init = options->inits[k];
    const std::string init_path = options_path + ".inits[" + std::to_string(k) + "]";
    if (init.kind == PinInit::Kind::servo && (init.safe_value < 0 || init.safe_value > 180)) {
      devices::fail_config(init_path + ".safe_position", "must be in 0..180");
    }
    if (init.kind == PinInit::Kind::digital && init.safe_value != 0 && init.safe_value != 1) {
      devices::fail_config(init_path + ".safe_state", "must be 0 or 1");
    }
    for (std::size_t j = 0; j < k; ++j) {
      if (options->inits[j].kind == init.kind && options->inits[j].pin == init.pin) {
        devices::fail_config(init_path, std::string(kind_name(init.kind)) + " " + std::to_string(init.pin) +
                                            " is already initialised by inits[" + std::to_string(j) + "]");
      }
    }
  }
}

devices::DeviceClient open_proxy(std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
                                 std::shared_ptr<client::LinkClock> clock) {
  Options client_options = device.options.get<DeviceOptions>().client;
  client_options.clock = std::move(clock);
  return std::make_shared<Client>(std::move(stream), std::move(client_options));
}

void await_proxy(const devices::DeviceClient& device_client, const devices::DeviceConfig& device,
                 const std::string& path) {
  Client& client = *device_client.get<Client>();
  const auto& options = device.options.get<DeviceOptions>();
  auto state = std::make_shared<ProxyReadiness>();
  const bool primary = options.client.mode == Mode::primary;
  const EventHandlerId handler = client.on_event([state](const Event& event) {
    std::lock_guard lock(state->mutex);
    if (std::holds_alternative<events::SessionEstablished>(event)) state->established = true;
    if (const auto* failed = std::get_if<events::LinkFailed>(&event)) state->link_error = failed->error;
    state->changed.notify_all();
  });
  {
    std::lock_guard lock(state->mutex);
    state->inits_pending = options.inits.size();
    if (client.session().established) state->established = true;
  }
  for (std::size_t i = 0; i < options.inits.size(); ++i) {
    const PinInit& init = options.inits[i];
    auto done = [state, i](error_code error, SendResult) {
      std::lock_guard lock(state->mutex);
      --state->inits_pending;
      if (error && !state->failed_init) {
        state->failed_init = i;
        state->init_error = error;
      }
      state->changed.notify_all();
    };
    if (init.kind == PinInit::Kind::servo) {
      client.servo(init.pin).async_init(init.safe_value, std::move(done));
    } else {
      client.digital(init.pin).async_init(init.safe_value != 0, std::move(done));
    }
  }
  std::unique_lock lock(state->mutex);
  const bool finished = state->changed.wait_for(lock, options.open_timeout, [&] {
    return state->failed_init.has_value() || state->link_error.failed() ||
           (state->inits_pending == 0 && (state->established || !primary));
  });
  const auto failed_init = state->failed_init;
  const error_code init_error = state->init_error;
  const error_code link_error = state->link_error;
  const bool established = state->established;
  lock.unlock();
  client.remove_event_handler(handler);

  if (link_error) fail_open(path + ".transport", "the link failed: " + link_error.message(), link_error);
  if (failed_init) {
    fail_open(path + ".options.inits[" + std::to_string(*failed_init) + "]",
              init_text(options.inits[*failed_init]) + ": " + init_error.message(), init_error);
  }
  if (!finished) {
    const auto limit = std::to_string(options.open_timeout.count());
    if (primary && !established) {
      fail_open(path,
                "no proxy session within " + limit + " ms (no ResetEvent answered our Reset: is the device " +
                    "running proxy firmware, at the right baud rate?)",
                devices::make_error_code(devices::DevicesError::device_not_ready));
    }
    fail_open(path + ".options.inits", "the inits did not complete within " + limit + " ms",
              devices::make_error_code(devices::DevicesError::device_not_ready));
  }
}

}  // namespace


transports::BootSignature boot_signature() {
  transports::BootSignature signature;
  signature.name = "ResetEvent frame";
  // From the first 0x00 on, so the frame reaches the client, whose session starts from it.
  signature.find_announcement = [](std::string_view received) -> std::optional<std::size_t> {
    std::size_t start = 0;
    if (!find_boot_frame(reinterpret_cast<const std::uint8_t*>(received.data()), received.size(), start)) {
      return std::nullopt;
    }
    return start;
  };
  return signature;
}

// Captures: a frame is COBS bytes up to their 0x00, with the 0x00 a sender writes in front of a frame to
// flush line garbage; bounded by the largest frame of the client's largest payload.
transports::CaptureFraming capture_framing(const devices::DeviceConfig&) {
  return [](bool) -> std::unique_ptr<transports::CaptureFramer> {
    return std::make_unique<transports::DelimitedFramer>(transports::DelimitedFraming::cobs(max_frame_size(kMaxPayload)));
  };
}

namespace {

// One frame's payload (leading 0x00s, COBS, the CRC checked in primary mode); nothing when it is damaged.
std::optional<std::string> frame_payload(std::span<const std::uint8_t> bytes, Integrity integrity) {
  LinkCounters counters;
  Decoder<kMaxPayload> decoder(integrity, counters);
  for (const std::uint8_t byte : bytes) {
    const DecodeStatus status = decoder.feed(byte);
    if (status == DecodeStatus::error) return std::nullopt;
    if (status == DecodeStatus::frame) {
      const ByteView payload = decoder.frame();
      return std::string(reinterpret_cast<const char*>(payload.data()), payload.size());
    }
  }
  return std::nullopt;
}

std::vector<std::uint8_t> frame_of(const google::protobuf::Message& message, Integrity integrity, bool leading) {
  const std::string payload = message.SerializeAsString();
  std::vector<std::uint8_t> frame(max_frame_size(payload.size()));
  const Result<std::size_t> written = encode_frame(ByteView::from_chars(payload.data(), payload.size()), integrity,
                                                   leading, MutableByteView(frame.data(), frame.size()));
  frame.resize(written.ok() ? written.value() : 0);
  return frame;
}

// Playing a recorded proxy device (primary mode): a request is its ArduinoIn without the messageId (the live
// host numbers its own), an Ack goes out with the live id of the message its recorded id matched, the
// CRC-16 and COBS over the new payload; every other message (ResetEvent with its recorded sessionId,
// PinState, Error, ArduinoInfo) as recorded. A ping is acked whenever it comes, as the device acks it; a
// message the recording does not have is refused as the device refuses one it cannot run: an Error saying
// why, then its Ack with `refused`.
class ProxyReplayer final : public transports::CaptureReplayer {
 public:
  transports::ReplayRequest classify(std::span<const std::uint8_t> frame) override {
    ArduinoIn message;
    if (!parse(frame, message)) return {};
    message.clear_messageid();
    const bool ping = message.data_case() == ArduinoIn::kPing;
    return {ping ? transports::ReplayRequest::Kind::keepalive : transports::ReplayRequest::Kind::request,
            message.ShortDebugString()};
  }

  void matched(std::span<const std::uint8_t> recorded, std::span<const std::uint8_t> live) override {
    ArduinoIn was;
    ArduinoIn now;
    if (parse(recorded, was) && parse(live, now)) ids_[was.messageid()] = now.messageid();
  }

  std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) override {
    std::vector<std::uint8_t> same(recorded.begin(), recorded.end());
    const std::optional<std::string> payload = frame_payload(recorded, Integrity::crc16);
    ArduinoOut message;
    if (!payload || !parse_device_message(message, ByteView::from_chars(payload->data(), payload->size())) ||
        !message.has_ack()) {
      return same;
    }
    const auto live = ids_.find(message.ack().messageid());
    if (live == ids_.end()) return std::nullopt;  // a recorded ping's ack, or a message the live host did not send
    message.mutable_ack()->set_messageid(live->second);
    return frame_of(message, Integrity::crc16, !recorded.empty() && recorded[0] == 0);
  }

  std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t> live) override {
    ArduinoIn request;
    if (!parse(live, request)) return {};  // the device drops a damaged frame (and counts it)
    std::vector<std::vector<std::uint8_t>> frames;
    const bool ping = request.data_case() == ArduinoIn::kPing;
    if (!ping) {
      ArduinoOut error;
      error.mutable_error()->set_text("replay: not the recorded message");
      error.mutable_error()->set_level(Error::WARNING);
      frames.push_back(frame_of(error, Integrity::crc16, false));
    }
    ArduinoOut ack;
    ack.mutable_ack()->set_messageid(request.messageid());
    ack.mutable_ack()->set_refused(!ping);
    frames.push_back(frame_of(ack, Integrity::crc16, false));
    return frames;
  }

 private:
  static bool parse(std::span<const std::uint8_t> frame, ArduinoIn& message) {
    const std::optional<std::string> payload = frame_payload(frame, Integrity::crc16);
    return payload && message.ParseFromString(*payload);
  }

  std::map<std::uint32_t, std::uint32_t> ids_;  // recorded messageId -> the live message's
};

// proxy-compat: no ids, no CRC, no acks. A request is the whole message; answers go as recorded; the
// deployed firmware answers a message it cannot run with an ErrorMessage of its own kind, which the
// recording cannot say, so a message it does not have is answered with nothing.
class CompatReplayer final : public transports::CaptureReplayer {
 public:
  transports::ReplayRequest classify(std::span<const std::uint8_t> frame) override {
    const std::optional<std::string> payload = frame_payload(frame, Integrity::none);
    RocketryProto::ArduinoIn message;
    if (!payload || !message.ParseFromString(*payload)) return {};
    return {transports::ReplayRequest::Kind::request, message.ShortDebugString()};
  }
  void matched(std::span<const std::uint8_t>, std::span<const std::uint8_t>) override {}
  std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) override {
    return std::vector<std::uint8_t>(recorded.begin(), recorded.end());
  }
  std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t>) override { return {}; }
};

}  // namespace

std::unique_ptr<transports::CaptureReplayer> capture_replayer(Mode mode) {
  if (mode == Mode::primary) return std::make_unique<ProxyReplayer>();
  return std::make_unique<CompatReplayer>();
}

std::vector<devices::CodecRow> codec_rows() {
  std::vector<devices::CodecRow> rows(2);
  // proxy and proxy-compat: one client and parser, the mode from the codec.
  const auto fill = [](devices::CodecRow& row, devices::Codec codec, std::string_view name,
                       std::string_view client_name) {
    row.codec = codec;
    row.name = name;
    row.client_name = client_name;
    row.client_type = &typeid(Client);
    row.parse_options = parse_proxy;
    row.validate = [codec](const devices::CodecOptions& options, const std::string& path) {
      validate_proxy(options, path, codec);
    };
    row.open = open_proxy;
    row.await_ready = await_proxy;
    row.capture_framing = capture_framing;
  };
  fill(rows[0], kCodec, "proxy", "proxy::Client");
  rows[0].capture_replay = [](const devices::DeviceConfig&) { return capture_replayer(Mode::primary); };
  rows[0].option_keys = {
      "baud",           "bits_per_byte",    "processing_margin_ms", "send_budget_ms", "max_sends", "queue_timeout_ms",
      "ping_period_ms", "reset_timeout_ms", "open_timeout_ms",      "inits"};
  rows[0].boot = boot_signature();
  rows[0].capture_words = [](const devices::DeviceConfig&) -> std::string { return "crc=on"; };
  fill(rows[1], kCompatCodec, "proxy-compat", "proxy::Client (proxy::Options::compat())");
  rows[1].option_keys = {"queue_timeout_ms", "stale_after_ms", "replay_on_reset", "open_timeout_ms", "inits"};
  rows[1].default_baud = 57600;  // the deployed firmware's
  rows[1].capture_replay = [](const devices::DeviceConfig&) { return capture_replayer(Mode::compat); };
  return rows;
}

}  // namespace tether::proxy
