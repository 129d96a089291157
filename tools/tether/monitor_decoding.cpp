// What `tether monitor` makes of a byte stream (see monitor_decoding.hpp).
#include "monitor_decoding.hpp"

#include <cstdio>
#include <variant>

#include "message_text.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/plugin.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/romi/decoder.hpp"

namespace tether::cli {

const char* to_string(Direction direction) {
  return direction == Direction::device_to_host ? "device->host" : "host->device";
}

std::string record_text(const MonitorRecord& record) {
  std::string line = record.kind;
  line.append(record.kind.size() < 8 ? 8 - record.kind.size() : 0, ' ');
  return line + " " + record.detail;
}

nlohmann::ordered_json record_json(const MonitorRecord& record) {
  nlohmann::ordered_json object = {{"kind", record.kind}};
  for (const auto& [key, value] : record.json.items()) object[key] = value;
  return object;
}

namespace {

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

MonitorRecord resync_record() {
  return {"resync", "skipped bytes to the next frame start", nlohmann::ordered_json::object(), false};
}

// Requests (host->device) and responses (device->host) share the envelope, so one decoder serves both.
class RomiDecoder final : public MonitorDecoder {
 public:
  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const DecodeStatus status = decoder_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    if (status == DecodeStatus::more) return;
    const romi::Frame& event = decoder_.frame();
    const std::string payload(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
    char id[4];
    std::snprintf(id, sizeof id, "%02x", event.id);
    if (status == DecodeStatus::frame && event.log) {
      records.push_back({"log", printable(payload), {{"text", payload}}, true});
    } else if (status == DecodeStatus::frame) {
      nlohmann::ordered_json json = {
          {"opcode", std::string(1, event.opcode)},
          {"id", event.manual ? nlohmann::ordered_json() : nlohmann::ordered_json(event.id)},
          {"manual", event.manual},
          {"payload", payload}};
      // An empty payload (`#:xxxx`, which the reference firmware sends) has no values after an opcode.
      if (payload.size() > 1) {
        const auto values = nlohmann::ordered_json::parse(payload.begin() + 1, payload.end(), nullptr, false);
        if (!values.is_discarded()) json["values"] = values;
      }
      const std::string shown = payload.empty() ? std::string("(empty)") : printable(payload);
      records.push_back({"frame", shown + (event.manual ? " (manual)" : " id " + std::string(id)), json, true});
    } else {
      const auto code = static_cast<std::int16_t>(decoder_.error());
      std::string detail = std::to_string(code) + " " + romi::describe(code);
      nlohmann::ordered_json json = {{"code", code}, {"message", romi::describe(code)}};
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
    }
  }
  LinkCounters counters() const override { return counters_; }

 private:
  LinkCounters counters_;
  romi::Decoder<1030> decoder_{counters_};  // responses and log lines up to 1024 bytes, like the client
};

class ProxyDecoder final : public MonitorDecoder {
 public:
  ProxyDecoder(proxy::Mode mode, const DecoderRole& role, Millis now)
      : mode_(mode),
        direction_(role.direction),
        keepalive_(role.keepalive && mode == proxy::Mode::primary),
        decoder_(mode == proxy::Mode::primary ? proxy::Integrity::crc16 : proxy::Integrity::none, counters_),
        next_ping_(now) {}

  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const DecodeStatus status = decoder_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    if (status == DecodeStatus::error) {
      const char* cause = proxy::describe(decoder_.error());
      records.push_back({"error", cause, {{"status", cause}}, false});
      return;
    }
    if (status != DecodeStatus::frame) return;
    const ByteView payload = decoder_.frame();
    const std::unique_ptr<google::protobuf::Message> message = schema_message();
    if (!proxy::parse_device_message(*message, payload)) {
      const std::string bytes = hex(payload);
      records.push_back({"undecodable", bytes, {{"payload_hex", bytes}}, false});
      return;
    }
    records.push_back({"message", describe_proxy_message(*message), proxy_message_json(*message), true});
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
  // The message type of this direction in this mode's schema.
  std::unique_ptr<google::protobuf::Message> schema_message() const {
    const bool primary = mode_ == proxy::Mode::primary;
    if (direction_ == Direction::host_to_device) {
      if (primary) return std::make_unique<proxy::ArduinoIn>();
      return std::make_unique<RocketryProto::ArduinoIn>();
    }
    if (primary) return std::make_unique<proxy::ArduinoOut>();
    return std::make_unique<RocketryProto::ArduinoOut>();
  }

  proxy::Mode mode_;
  Direction direction_;
  bool keepalive_;
  LinkCounters counters_;
  proxy::Decoder<proxy::kMaxPayload> decoder_;
  Millis next_ping_;
  std::uint32_t message_id_ = 0x4d4f4e00;  // "MON": far from a client's ids
};

MonitorRecord elcano_record(const char* kind, const elcano::Message& message, elcano::Generation generation) {
  const std::string text = format_elcano(message, generation);
  return {kind, text, {{"text", text}, {"message", elcano_json(message)}}, true};
}

MonitorRecord elcano_error_record(elcano::Error error) {
  return {"error", elcano::describe(error), {{"reason", elcano::describe(error)}}, false};
}

// The host's node of an Elcano ring: captures, forwards the rest (paced), as `RingClient` would.
class ElcanoRingNodeDecoder final : public MonitorDecoder {
 public:
  ElcanoRingNodeDecoder(const elcano::DeviceOptions& options, Millis now)
      : generation_(options.generation), node_(config(options), now, counters_, ring_) {}

  void feed(std::uint8_t byte, Millis now, std::vector<MonitorRecord>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const elcano::RingEvent event = node_.feed(byte, now);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    add(event, records);
  }

  void poll(Millis now, std::vector<MonitorRecord>& records) override {
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
  static elcano::RingNodeConfig config(const elcano::DeviceOptions& options) {
    elcano::RingNodeConfig node;
    node.generation = options.generation;
    node.capture = options.capture;
    node.pacing = options.pacing;
    return node;
  }

  void add(const elcano::RingEvent& event, std::vector<MonitorRecord>& records) const {
    switch (event.kind) {
      case elcano::RingEvent::Kind::none:
        return;
      case elcano::RingEvent::Kind::captured:
      case elcano::RingEvent::Kind::forwarded:
      case elcano::RingEvent::Kind::undeliverable:
        records.push_back(elcano_record(elcano::to_string(event.kind), event.message, generation_));
        return;
      case elcano::RingEvent::Kind::dropped:
        records.push_back(elcano_error_record(event.error));
        return;
    }
  }

  elcano::Generation generation_;
  LinkCounters counters_;
  elcano::RingCounters ring_;
  elcano::RingNode<96, 256, 4> node_;
};

// Elcano messages seen on a tapped link: decoded only (the tap passes the bytes on itself).
class ElcanoReaderDecoder final : public MonitorDecoder {
 public:
  explicit ElcanoReaderDecoder(elcano::Generation generation)
      : generation_(generation), reader_(generation, counters_) {}

  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const DecodeStatus status = reader_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    if (status == DecodeStatus::frame) records.push_back(elcano_record("message", reader_.frame(), generation_));
    if (status == DecodeStatus::error) records.push_back(elcano_error_record(reader_.error()));
  }

  LinkCounters counters() const override { return counters_; }

 private:
  elcano::Generation generation_;
  LinkCounters counters_;
  elcano::Decoder<96> reader_;
};

}  // namespace

std::unique_ptr<MonitorDecoder> make_romi_monitor_decoder(const devices::DeviceConfig&, const DecoderRole&, Millis) {
  return std::make_unique<RomiDecoder>();
}

std::unique_ptr<MonitorDecoder> make_proxy_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                           Millis now) {
  return std::make_unique<ProxyDecoder>(config.options.get<proxy::DeviceOptions>().client.mode, role, now);
}

std::unique_ptr<MonitorDecoder> make_elcano_monitor_decoder(const devices::DeviceConfig& config,
                                                            const DecoderRole& role, Millis now) {
  const auto& options = config.options.get<elcano::DeviceOptions>();
  if (role.ring_node) return std::make_unique<ElcanoRingNodeDecoder>(options, now);
  return std::make_unique<ElcanoReaderDecoder>(options.generation);
}

}  // namespace tether::cli
