// `tether monitor DEVICE [options]`: decodes and prints everything a device sends, one line per frame or
// message, damaged frames and resynchronisations included, with timestamps.
//
// It reads the device's byte stream with the codec's portable decoder (no client: no session, no Reset,
// no pings), so it is passive: romi and proxy devices get nothing at all (proxy: unless --keepalive); an
// Elcano ring gets what a ring node must send, every message the host does not capture, forwarded.
//
// Output contract: one line per event on stdout, `<time> <kind> <detail>`; with --json one JSON object
// per line instead. Exit status: 0 when --count or --duration is reached or on SIGINT/SIGTERM; 2 for usage
// errors, a device that cannot be opened, or a link that fails (the device went away).
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "message_text.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/proxy/frame.hpp"
#include "tether/romi/envelope_decoder.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::cli {

namespace {

namespace asio = boost::asio;

const CommandText& command_text() {
  static const CommandText text(
      "monitor",
      std::string(
          "usage: tether monitor DEVICE [--utc] [--json] [--count N] [--duration S] [--keepalive]\n"
          "\n"
          "Decodes and prints everything the device sends, one line per frame or message, with a timestamp\n"
          "(milliseconds since the start, or ISO 8601 UTC with --utc): romi responses and log lines, proxy\n"
          "messages (ArduinoOut of the mode's schema), Elcano messages; and what the decoder dropped (CRC\n"
          "errors, malformed or oversize frames, undecodable payloads) and each resynchronisation:\n"
          "  12.345 frame    e[0,1,2] id 07\n"
          "  13.001 log      motor: ready\n"
          "  20.500 error    -4 crc mismatch (opcode e, id 08)\n"
          "  20.512 resync   skipped bytes to the next frame start\n"
          "\n"
          "Passive: it opens the device's byte stream without a client, so romi and proxy devices receive\n"
          "nothing (a proxy device in primary mode fails safe after 10 s without pings; --keepalive sends it a\n"
          "Ping every second, whose acks then show up). An Elcano ring receives what the protocol requires of\n"
          "the host's node: every message it does not capture (--capture; default none) is forwarded to the\n"
          "next board, paced, exactly as `RingClient` would, and shown as `forwarded`.\n"
          "\n") +
      kDeviceUsage +
      "\n"
      "  --utc          ISO 8601 UTC wall-clock timestamps instead of milliseconds since the start\n"
      "  --json         one JSON object per line: {\"t_ms\":12.345,\"kind\":\"frame\",...} (\"time\" with --utc)\n"
      "  --count N      stop after N frames or messages (log lines included; errors and resyncs not counted)\n"
      "  --duration S   stop after S seconds (decimals allowed)\n"
      "  --keepalive    proxy primary mode: send a Ping every second (the only thing monitor then sends)\n"
      "\n"
      "Runs until --count, --duration, SIGINT or SIGTERM (exit status 0). Exit status 2: usage errors, a\n"
      "device that cannot be opened, a link that failed (the device went away).\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct Arguments {
  DeviceOptions device;
  bool utc = false;
  bool json = false;
  bool keepalive = false;
  std::optional<std::uint32_t> count;
  std::optional<std::uint32_t> duration_ms;
};

std::optional<int> parse(int argc, char** argv, Arguments& arguments) {
  const CommandText& text = command_text();
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--utc") {
      arguments.utc = true;
    } else if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--keepalive") {
      arguments.keepalive = true;
    } else if (argument == "--count" || argument == "--duration") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--count") {
        arguments.count = parse_number(value, 1, 0xFFFFFFFFu);
        if (!arguments.count)
          return text.usage_error("--count needs a positive number, got '" + std::string(value) + "'");
      } else {
        arguments.duration_ms = parse_seconds(value, 30.0 * 24 * 3600);
        if (!arguments.duration_ms)
          return text.usage_error("--duration needs seconds, got '" + std::string(value) + "'");
      }
    } else {
      return text.unexpected_argument(argument);
    }
    return std::nullopt;
  };
  return parse_device_arguments(argc, argv, text, arguments.device, own);
}

// One line of output.
struct Record {
  std::string kind;             // frame, log, message, forwarded, captured, undecodable, error, resync
  std::string detail;           // the text after the kind
  nlohmann::ordered_json json;  // the fields after "kind"
  bool counted = false;         // counts towards --count
};

std::string hex(ByteView bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  for (const std::uint8_t byte : bytes) {
    if (!text.empty()) text += ' ';
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0x0F];
  }
  return text;
}

Record resync_record() {
  return {"resync", "skipped bytes to the next frame start", nlohmann::ordered_json::object(), false};
}

// A codec's receiving side, fed with the device's bytes.
class Decoder {
 public:
  virtual ~Decoder() = default;
  /// Decodes `byte`, appending what it produced.
  virtual void feed(std::uint8_t byte, Millis now, std::vector<Record>& records) = 0;
  /// Handles deadlines (elcano).
  virtual void poll(Millis, std::vector<Record>&) {}
  /// Bytes the protocol requires the host to send now (elcano forwarding, proxy keepalive pings).
  virtual std::string output(Millis) { return {}; }
  /// True while output is waiting for its pacing (what `output` will still return).
  virtual bool output_pending() const { return false; }
  /// When `poll`/`output` next has something to do, in ms from `now` (nothing: no deadline).
  virtual std::optional<Duration> next_wakeup(Millis) { return std::nullopt; }
  /// The decoder's counters.
  virtual LinkCounters counters() const = 0;
};

class RomiDecoder final : public Decoder {
 public:
  void feed(std::uint8_t byte, Millis, std::vector<Record>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const romi::EnvelopeEvent event = decoder_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    const std::string payload(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
    char id[4];
    std::snprintf(id, sizeof id, "%02x", event.id);
    switch (event.kind) {
      case romi::EnvelopeEvent::Kind::none:
        break;
      case romi::EnvelopeEvent::Kind::log:
        records.push_back({"log", payload, {{"text", payload}}, true});
        break;
      case romi::EnvelopeEvent::Kind::frame: {
        nlohmann::ordered_json json = {
            {"opcode", std::string(1, event.opcode)},
            {"id", event.manual ? nlohmann::ordered_json() : nlohmann::ordered_json(event.id)},
            {"manual", event.manual},
            {"payload", payload}};
        const auto values = nlohmann::ordered_json::parse(payload.substr(1), nullptr, false);
        if (!values.is_discarded()) json["values"] = values;
        records.push_back({"frame", payload + (event.manual ? " (manual)" : " id " + std::string(id)), json, true});
        break;
      }
      case romi::EnvelopeEvent::Kind::error: {
        const auto code = static_cast<std::int16_t>(event.error);
        std::string detail = std::to_string(code) + " " + romi::message(code);
        nlohmann::ordered_json json = {{"code", code}, {"message", romi::message(code)}};
        if (event.opcode != '_') {
          detail += " (opcode " + std::string(1, event.opcode);
          json["opcode"] = std::string(1, event.opcode);
          if (event.has_id) {
            detail += ", id " + std::string(id);
            json["id"] = event.id;
          }
          detail += ")";
        }
        records.push_back({"error", detail, json, false});
        break;
      }
    }
  }
  LinkCounters counters() const override { return counters_; }

 private:
  LinkCounters counters_;
  romi::EnvelopeDecoder<1030> decoder_{counters_};  // responses and log lines up to 1024 bytes, like the client
};

class ProxyDecoder final : public Decoder {
 public:
  ProxyDecoder(proxy::Mode mode, bool keepalive, Millis now)
      : mode_(mode),
        keepalive_(keepalive && mode == proxy::Mode::primary),
        decoder_(mode == proxy::Mode::primary ? proxy::Integrity::crc16 : proxy::Integrity::none, counters_),
        next_ping_(now) {}

  void feed(std::uint8_t byte, Millis, std::vector<Record>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const proxy::FrameEvent event = decoder_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    if (event.kind == proxy::FrameEvent::Kind::error) {
      records.push_back({"error", to_string(event.status), {{"status", to_string(event.status)}}, false});
      return;
    }
    if (event.kind != proxy::FrameEvent::Kind::payload) return;
    std::unique_ptr<google::protobuf::Message> message;
    if (mode_ == proxy::Mode::primary) {
      message = std::make_unique<proxy::ArduinoOut>();
    } else {
      message = std::make_unique<RocketryProto::ArduinoOut>();
    }
    if (!message->ParseFromArray(event.payload.data(), static_cast<int>(event.payload.size()))) {
      const std::string bytes = hex(event.payload);
      records.push_back({"undecodable", bytes, {{"payload_hex", bytes}}, false});
      return;
    }
    nlohmann::ordered_json json = proxy_message_json(*message);
    records.push_back({"message", describe_proxy_message(*message), json, true});
  }

  std::string output(Millis now) override {
    if (!keepalive_ || !tick_reached(now, next_ping_)) return {};
    next_ping_ = static_cast<Millis>(now + 1000);
    proxy::ArduinoIn ping;
    ping.set_messageid(++message_id_);
    ping.mutable_ping();
    const std::string payload = ping.SerializeAsString();
    std::uint8_t frame[proxy::max_frame_size(32)];
    const Result<std::size_t> written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                            proxy::Integrity::crc16, true, MutableByteView(frame));
    if (!written.ok()) return {};
    return std::string(reinterpret_cast<const char*>(frame), written.value());
  }

  std::optional<Duration> next_wakeup(Millis now) override {
    if (!keepalive_) return std::nullopt;
    const std::int32_t left = tick_difference(next_ping_, now);
    return left > 0 ? static_cast<Duration>(left) : 0;
  }

  LinkCounters counters() const override { return counters_; }

 private:
  proxy::Mode mode_;
  bool keepalive_;
  LinkCounters counters_;
  proxy::FrameDecoder<proxy::kMaxPayload> decoder_;
  Millis next_ping_;
  std::uint32_t message_id_ = 0x4d4f4e00;  // "MON": far from a client's ids
};

class ElcanoDecoder final : public Decoder {
 public:
  ElcanoDecoder(const devices::ElcanoOptions& options, Millis now)
      : generation_(options.generation), node_(config(options), now, counters_, ring_) {}

  void feed(std::uint8_t byte, Millis now, std::vector<Record>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const elcano::RingEvent event = node_.feed(byte, now);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    add(event, records);
  }

  void poll(Millis now, std::vector<Record>& records) override {
    for (;;) {
      const elcano::RingEvent event = node_.poll(now);
      if (event.kind == elcano::RingEvent::Kind::none) break;
      add(event, records);
    }
  }

  std::string output(Millis now) override {
    std::uint8_t bytes[256];
    const std::size_t size = node_.take_output(MutableByteView(bytes), now);
    return std::string(reinterpret_cast<const char*>(bytes), size);
  }

  bool output_pending() const override { return node_.pending_output() > 0; }

  std::optional<Duration> next_wakeup(Millis now) override {
    const Deadline deadline = node_.next_wakeup(now);
    if (!deadline.armed()) return std::nullopt;
    return deadline.remaining(now);
  }

  LinkCounters counters() const override { return counters_; }

 private:
  static elcano::RingNodeConfig config(const devices::ElcanoOptions& options) {
    elcano::RingNodeConfig node;
    node.generation = options.generation;
    node.capture = options.capture;
    node.pacing = options.pacing;
    return node;
  }

  void add(const elcano::RingEvent& event, std::vector<Record>& records) const {
    switch (event.kind) {
      case elcano::RingEvent::Kind::none:
        return;
      case elcano::RingEvent::Kind::captured:
      case elcano::RingEvent::Kind::forwarded:
      case elcano::RingEvent::Kind::undeliverable: {
        const char* kind = elcano::to_string(event.kind);
        const std::string text = format_elcano(event.message, generation_);
        nlohmann::ordered_json json = {{"text", text}, {"message", elcano_json(event.message)}};
        records.push_back({kind, text, json, true});
        return;
      }
      case elcano::RingEvent::Kind::dropped:
        records.push_back(
            {"error", elcano::to_string(event.error), {{"reason", elcano::to_string(event.error)}}, false});
        return;
    }
  }

  elcano::Generation generation_;
  LinkCounters counters_;
  elcano::RingCounters ring_;
  elcano::RingNode<96, 256, 4> node_;
};

}  // namespace

int run_monitor(int argc, char** argv) {
  Arguments arguments;
  if (const auto status = parse(argc, argv, arguments)) return *status;
  std::string error;
  const auto target = resolve_device(arguments.device, devices::Codec::romi, error);
  if (!target) return command_text().usage_error(error);
  const devices::Codec codec = target->config.codec;
  if (arguments.keepalive && codec != devices::Codec::proxy) {
    return command_text().usage_error("--keepalive applies to the proxy codec (primary mode) only");
  }

  transports::IoThread io;
  Progress progress("monitor");
  auto stream = open_stream(*target, io.executor(), progress, error);
  if (!stream) return command_text().fail(target->label + ": " + error);

  const std::atomic<bool>& stop = catch_stop_signals();

  const auto start = std::chrono::steady_clock::now();
  auto now_ms = [&] {
    return static_cast<Millis>(
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start).count());
  };
  std::unique_ptr<Decoder> decoder;
  switch (codec) {
    case devices::Codec::romi:
      decoder = std::make_unique<RomiDecoder>();
      break;
    case devices::Codec::proxy:
    case devices::Codec::proxy_compat:
      decoder = std::make_unique<ProxyDecoder>(
          std::get<devices::ProxyDeviceOptions>(target->config.options).client.mode, arguments.keepalive, now_ms());
      break;
    case devices::Codec::elcano:
      decoder = std::make_unique<ElcanoDecoder>(std::get<devices::ElcanoOptions>(target->config.options), now_ms());
      break;
  }

  const Timestamps stamps(arguments.utc);
  std::uint32_t counted = 0;
  int status = 0;
  std::array<std::uint8_t, 1024> buffer{};
  std::vector<Record> records;
  auto print = [&](const Record& record) {
    if (arguments.json) {
      nlohmann::ordered_json object;
      stamps.add_to(object);
      object["kind"] = record.kind;
      for (const auto& [key, value] : record.json.items()) object[key] = value;
      out().line(dump(object));
    } else {
      std::string line = stamps.text() + " " + record.kind;
      line.append(record.kind.size() < 8 ? 8 - record.kind.size() : 0, ' ');
      out().line(line + " " + record.detail);
    }
  };

  bool done = false;
  while (!done && !stop) {
    const Millis now = now_ms();
    // Whatever the protocol requires us to send (elcano forwarding, keepalive pings).
    decoder->poll(now, records);
    for (std::string bytes = decoder->output(now); !bytes.empty(); bytes = decoder->output(now_ms())) {
      boost::system::error_code write_error;
      stream->write(asio::buffer(bytes), write_error);
      if (write_error) {
        std::fprintf(stderr, "tether monitor: the link failed: %s\n", write_error.message().c_str());
        status = 2;
        done = true;
        break;
      }
    }
    // Wait for bytes at most until the next deadline (and 100 ms, to notice a stop signal).
    Duration wait = 100;
    if (const auto wakeup = decoder->next_wakeup(now)) wait = std::min<Duration>(wait, std::max<Duration>(*wakeup, 1));
    if (arguments.duration_ms) {
      const auto elapsed = std::chrono::steady_clock::now() - start;
      const auto left = std::chrono::milliseconds(*arguments.duration_ms) -
                        std::chrono::duration_cast<std::chrono::milliseconds>(elapsed);
      if (left.count() <= 0) break;
      wait = std::min<Duration>(wait, static_cast<Duration>(left.count()));
    }
    std::size_t size = 0;
    if (!done) {
      boost::system::error_code read_error;
      size = stream->read_some(asio::buffer(buffer), std::chrono::milliseconds(wait), read_error);
      if (read_error && read_error != transports::TransportError::timed_out) {
        std::fprintf(stderr, "tether monitor: the link failed: %s\n", read_error.message().c_str());
        status = 2;
        done = true;
      }
    }
    const Millis fed_at = now_ms();
    for (std::size_t i = 0; i < size; ++i) decoder->feed(buffer[i], fed_at, records);
    for (const Record& record : records) {
      print(record);
      if (record.counted && arguments.count && ++counted >= *arguments.count) {
        done = true;
        break;
      }
    }
    records.clear();
  }
  // Messages already accepted for forwarding still leave (paced), so stopping does not cut the ring.
  const auto flush_limit = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (status == 0 && decoder->output_pending() && std::chrono::steady_clock::now() < flush_limit) {
    const std::string bytes = decoder->output(now_ms());
    boost::system::error_code write_error;
    if (!bytes.empty()) stream->write(asio::buffer(bytes), write_error);
    if (write_error) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  stream->close();
  return status;
}

}  // namespace tether::cli
