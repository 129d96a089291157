// The rpc codec's plugin (plugin.hpp): `rpc` devices in a configuration, their schema read at parse time,
// their clients, and opening's wait for the device's Hello with the same schema.
#include <condition_variable>
#include <filesystem>
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

#include "tether/devices/json_reader.hpp"
#include "tether/proxy/boot_frame.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/errors.hpp"
#include "tether/rpc/plugin.hpp"

#include <google/protobuf/descriptor.h>
#include <nlohmann/json.hpp>

#include "tether_rpc.pb.h"

namespace tether::rpc {

namespace {

// A virtual board's image may ship its schema beside it (`rpc-example.elf` and `rpc-example.proto`): the
// schema of a virtual device that names none.
std::filesystem::path schema_beside_image(const devices::OptionsContext& context) {
  const auto* board = std::get_if<devices::VirtualTransport>(context.transport);
  if (board == nullptr || board->board.firmware.empty()) return {};
  std::filesystem::path schema = board->board.firmware;
  schema.replace_extension(".proto");
  std::error_code error;
  return std::filesystem::is_regular_file(schema, error) ? schema : std::filesystem::path();
}

DeviceOptions parse_rpc_options(const devices::OptionsContext& context) {
  const std::optional<devices::JsonObject> object = context.object();
  DeviceOptions options;
  if (const auto* serial = std::get_if<devices::SerialTransport>(context.transport))
    options.client.timing.baud = serial->options.baud;
  if (object && object->optional("schema")) {
    options.schema = context.resolve_path(devices::read_nonempty_string(object->required("schema")));
  } else {
    options.schema = schema_beside_image(context);
    if (options.schema.empty()) {
      devices::fail_config(context.path, "missing key \"schema\" (an rpc device needs its schema file; a virtual "
                                         "board's image may have it beside it, IMAGE.proto)");
    }
  }
  if (!object) {
    (void)load_schema(options, context.path);
    return options;
  }
  if (auto v = object->optional("service")) options.schema_options.service = devices::read_nonempty_string(*v);
  if (auto v = object->optional("import_paths")) {
    if (!v->value.is_array()) v->expected("an array of folders");
    devices::for_each_element(*v, [&](const devices::JsonNode& element, std::size_t) {
      options.schema_options.import_paths.push_back(context.resolve_path(devices::read_nonempty_string(element)));
    });
  }
  RpcTiming& timing = options.client.timing;
  if (auto v = object->optional("baud"))
    timing.baud = static_cast<std::uint32_t>(devices::read_unsigned(*v, 1, 0xFFFFFFFFu));
  if (auto v = object->optional("bits_per_byte"))
    timing.bits_per_byte = static_cast<std::uint32_t>(devices::read_unsigned(*v, 1, 64));
  if (auto v = object->optional("processing_margin_ms")) timing.processing_margin = devices::read_ms(*v);
  if (auto v = object->optional("call_budget_ms")) timing.call_budget = devices::read_ms(*v, 1);
  if (auto v = object->optional("max_sends"))
    timing.max_sends = static_cast<std::uint8_t>(devices::read_unsigned(*v, 1, 255));
  if (auto v = object->optional("queue_timeout_ms")) timing.queue_timeout = devices::read_ms(*v, 1);
  if (auto v = object->optional("ping_period_ms")) timing.ping_period = devices::read_ms(*v);
  if (auto v = object->optional("hello_timeout_ms")) timing.hello_timeout = devices::read_ms(*v, 1);
  if (auto v = object->optional("first_message_id"))
    options.client.first_message_id = static_cast<std::uint32_t>(devices::read_unsigned(*v, 0, 0xFFFFFFFFu));
  if (auto v = object->optional("open_timeout_ms"))
    options.open_timeout = std::chrono::milliseconds(devices::read_ms(*v, 1));
  (void)load_schema(options, context.path);  // a broken schema is the configuration's error, found now
  return options;
}

void validate_rpc(const devices::CodecOptions& codec_options, const std::string& options_path) {
  const auto* options = codec_options.get_if<DeviceOptions>();
  if (options == nullptr) devices::fail_config(options_path, "codec rpc needs rpc::DeviceOptions");
  if (options->schema.empty()) devices::fail_config(options_path + ".schema", "must name the schema file");
  const RpcTiming& timing = options->client.timing;
  if (timing.baud == 0) devices::fail_config(options_path + ".baud", "must be at least 1");
  if (timing.bits_per_byte == 0) devices::fail_config(options_path + ".bits_per_byte", "must be at least 1");
  if (timing.call_budget == 0) devices::fail_config(options_path + ".call_budget_ms", "must be at least 1");
  if (timing.max_sends == 0) devices::fail_config(options_path + ".max_sends", "must be at least 1");
  if (timing.queue_timeout == 0) devices::fail_config(options_path + ".queue_timeout_ms", "must be at least 1");
  if (timing.hello_timeout == 0) devices::fail_config(options_path + ".hello_timeout_ms", "must be at least 1");
  if (options->open_timeout.count() <= 0) devices::fail_config(options_path + ".open_timeout_ms", "must be at least 1");
}

devices::DeviceClient open_rpc(std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
                               std::shared_ptr<client::LinkClock> clock) {
  const auto& options = device.options.get<DeviceOptions>();
  // Read again: the client owns its schema (the file was read once at parse time, for its errors; a
  // SchemaError now, the file changed since, is the opening's error at the device's options).
  Schema schema = Schema::load(options.schema, options.schema_options);
  Options client_options = options.client;
  client_options.clock = std::move(clock);
  return std::make_shared<Client>(std::move(stream), std::move(schema), client_options);
}

// What opening an rpc device waits for: the ready completion, or the first mismatch's text.
struct RpcReadiness {
  std::mutex mutex;
  std::condition_variable changed;
  bool done = false;
  error_code error;
  std::string mismatch;
};

std::string no_session_text(Duration waited_ms) {
  return "no rpc session within " + std::to_string(waited_ms) +
         " ms: no DeviceHello answered our Hello (is the device running an rpc image, at the right baud rate?)";
}

void await_rpc(const devices::DeviceClient& device_client, const devices::DeviceConfig& device,
               const std::string& path) {
  Client& client = *device_client.get<Client>();
  const auto& options = device.options.get<DeviceOptions>();
  auto state = std::make_shared<RpcReadiness>();
  const auto handler = client.on_event([state](const Event& event) {
    if (const auto* mismatch = std::get_if<events::SchemaMismatch>(&event)) {
      std::lock_guard lock(state->mutex);
      if (state->mismatch.empty()) state->mismatch = mismatch->text;
      state->changed.notify_all();
    }
  });
  client.async_wait_ready([state](error_code error, std::uint32_t) {
    std::lock_guard lock(state->mutex);
    state->done = true;
    state->error = error;
    state->changed.notify_all();
  });
  std::unique_lock lock(state->mutex);
  const bool finished = state->changed.wait_for(lock, options.open_timeout, [&] {
    return state->done || !state->mismatch.empty();
  });
  const error_code error = state->error;
  const std::string mismatch = state->mismatch;
  const bool done = state->done;
  lock.unlock();
  client.remove_event_handler(handler);

  if (!mismatch.empty() || (done && error == RpcError::schema_mismatch)) {
    // The wait may complete before the event reached its handler: then the same text from the session.
    const std::string text =
        !mismatch.empty() ? mismatch : mismatch_text(client.schema(), client.session().device_hash.value_or(0));
    throw devices::ConfigError(path + ".options.schema", text, make_error_code(RpcError::schema_mismatch));
  }
  if (done && error) {
    if (error == RpcError::queue_timeout) {  // the client's wait for a session ended first
      throw devices::ConfigError(path, no_session_text(options.client.timing.queue_timeout),
                                 devices::make_error_code(devices::DevicesError::device_not_ready));
    }
    throw devices::ConfigError(path + ".transport", "the link failed: " + error.message(), error);
  }
  if (!finished) {
    throw devices::ConfigError(path, no_session_text(static_cast<Duration>(options.open_timeout.count())),
                               devices::make_error_code(devices::DevicesError::device_not_ready));
  }
}

}  // namespace

Schema load_schema(const DeviceOptions& options, const std::string& options_path) {
  try {
    return Schema::load(options.schema, options.schema_options);
  } catch (const SchemaError& error) {
    devices::fail_config(options_path + ".schema", error.what());
  }
}

transports::BootSignature boot_signature() {
  transports::BootSignature signature;
  signature.name = "ResetEvent frame";
  // From the first 0x00 on, so the frame reaches the client, whose session starts from it.
  signature.find_announcement = [](std::string_view received) -> std::optional<std::size_t> {
    std::size_t start = 0;
    if (!proxy::find_boot_frame(reinterpret_cast<const std::uint8_t*>(received.data()), received.size(), start)) {
      return std::nullopt;
    }
    return start;
  };
  return signature;
}

// Captures: the proxy's frames (COBS, CRC-16 in front of the payload), bounded by the largest payload; the
// interface names the schema and its package, for a dissector that decodes the methods' fields.
transports::CaptureFraming capture_framing(const devices::DeviceConfig&) {
  return [](bool) -> std::unique_ptr<transports::CaptureFramer> {
    return std::make_unique<transports::DelimitedFramer>(transports::DelimitedFraming::cobs(proxy::max_frame_size(kMaxPayload)));
  };
}

std::string capture_words(const devices::DeviceConfig& device) {
  const auto* options = device.options.get_if<DeviceOptions>();
  if (options == nullptr) return "crc=on";
  std::string words = "schema=" + transports::capture_word_value(options->schema.string());
  try {
    const Schema schema = Schema::load(options->schema, options->schema_options);
    const std::string package = schema.service().file()->package();
    if (!package.empty()) words += " package=" + transports::capture_word_value(package);
  } catch (const std::exception&) {
    // Opening reports a schema that cannot be read; the capture then names the file only.
  }
  return words + " crc=on";
}

namespace {

// One frame's payload (leading 0x00s, COBS, CRC-16 checked); nothing when it is damaged.
std::optional<std::string> frame_payload(std::span<const std::uint8_t> bytes) {
  LinkCounters counters;
  proxy::Decoder<kMaxPayload> decoder(proxy::Integrity::crc16, counters);
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

std::vector<std::uint8_t> frame_of(const google::protobuf::Message& message, bool leading) {
  const std::string payload = message.SerializeAsString();
  std::vector<std::uint8_t> frame(proxy::max_frame_size(payload.size()));
  const Result<std::size_t> written =
      proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16, leading,
                          MutableByteView(frame.data(), frame.size()));
  frame.resize(written.ok() ? written.value() : 0);
  return frame;
}

// Playing a recorded rpc device: a request is its HostMessage without the id; the ids a device message carries (Ack.id, Reply.call, DeviceError.call,
// StreamMessage.stream) become the live ones of the messages they were recorded for, CRC-16 and COBS redone;
// DeviceHello and ResetEvent go as recorded (the live host learns the recorded session). A ping and a
// CloseStream are acked whenever they come and never waited for: a client that ends its process closes its
// stream on the way out, and the close may or may not get out before the port does. A message the recording lacks is refused as the device refuses a method it does not
// have: DeviceError{unknown_method}, then Ack{refused}.
class RpcReplayer final : public transports::CaptureReplayer {
 public:
  transports::ReplayRequest classify(std::span<const std::uint8_t> frame) override {
    wire::HostMessage message;
    if (!parse(frame, message)) return {};
    message.clear_id();
    const bool keepalive = message.has_ping() || message.has_close();
    return {keepalive ? transports::ReplayRequest::Kind::keepalive : transports::ReplayRequest::Kind::request,
            message.ShortDebugString()};
  }

  void matched(std::span<const std::uint8_t> recorded, std::span<const std::uint8_t> live) override {
    wire::HostMessage was;
    wire::HostMessage now;
    if (parse(recorded, was) && parse(live, now)) ids_[was.id()] = now.id();
  }

  std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) override {
    std::vector<std::uint8_t> same(recorded.begin(), recorded.end());
    const std::optional<std::string> payload = frame_payload(recorded);
    wire::DeviceMessage message;
    if (!payload || !message.ParseFromString(*payload)) return same;
    const auto live = [this](std::uint32_t id) -> std::optional<std::uint32_t> {
      const auto found = ids_.find(id);
      if (found == ids_.end()) return std::nullopt;
      return found->second;
    };
    std::optional<std::uint32_t> id;
    if (message.has_ack()) {
      if ((id = live(message.ack().id()))) message.mutable_ack()->set_id(*id);
    } else if (message.has_reply()) {
      if ((id = live(message.reply().call()))) message.mutable_reply()->set_call(*id);
    } else if (message.has_error()) {
      if (message.error().call() == 0) return same;  // not about a message (a frame that was no HostMessage)
      if ((id = live(message.error().call()))) message.mutable_error()->set_call(*id);
    } else if (message.has_stream()) {
      if ((id = live(message.stream().stream()))) message.mutable_stream()->set_stream(*id);
    } else {
      return same;
    }
    if (!id) return std::nullopt;  // about a message the live host did not send (a recorded ping's ack)
    return frame_of(message, !recorded.empty() && recorded[0] == 0);
  }

  std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t> live) override {
    wire::HostMessage request;
    if (!parse(live, request)) return {};  // a frame the device drops (and counts)
    std::vector<std::vector<std::uint8_t>> frames;
    const bool keepalive = request.has_ping() || request.has_close();
    if (!keepalive) {
      wire::DeviceMessage error;
      error.mutable_error()->set_call(request.id());
      error.mutable_error()->set_code(static_cast<std::uint32_t>(DeviceErrorCode::unknown_method));
      error.mutable_error()->set_text("replay: not the recorded message");
      frames.push_back(frame_of(error, false));
    }
    wire::DeviceMessage ack;
    ack.mutable_ack()->set_id(request.id());
    ack.mutable_ack()->set_refused(!keepalive);
    frames.push_back(frame_of(ack, false));
    return frames;
  }

 private:
  static bool parse(std::span<const std::uint8_t> frame, wire::HostMessage& message) {
    const std::optional<std::string> payload = frame_payload(frame);
    return payload && message.ParseFromString(*payload);
  }

  std::map<std::uint32_t, std::uint32_t> ids_;  // recorded message id -> the live message's
};

}  // namespace

std::unique_ptr<transports::CaptureReplayer> capture_replayer() { return std::make_unique<RpcReplayer>(); }

std::vector<devices::CodecRow> codec_rows() {
  devices::CodecRow row;
  row.codec = kCodec;
  row.name = "rpc";
  row.client_name = "rpc::Client";
  row.client_type = &typeid(Client);
  row.option_keys = {"schema",           "service",         "import_paths",   "baud",
                     "bits_per_byte",    "processing_margin_ms", "call_budget_ms", "max_sends",
                     "queue_timeout_ms", "ping_period_ms",  "hello_timeout_ms", "first_message_id",
                     "open_timeout_ms"};
  row.parse_options = [](const devices::OptionsContext& context) -> devices::CodecOptions {
    return parse_rpc_options(context);
  };
  row.validate = validate_rpc;
  row.open = open_rpc;
  row.await_ready = await_rpc;
  row.boot = boot_signature();
  row.capture_framing = capture_framing;
  row.capture_words = capture_words;
  row.capture_replay = [](const devices::DeviceConfig&) { return capture_replayer(); };
  return {row};
}

}  // namespace tether::rpc
