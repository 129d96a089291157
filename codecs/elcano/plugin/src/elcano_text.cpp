// The Elcano ring as the `tether` command shows it (see elcano_text.hpp).
#include "elcano_text.hpp"

#include <cstdint>
#include <utility>

#include "cli_support.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/plugin.hpp"

namespace tether::cli {

std::optional<elcano::Message> parse_elcano(std::string_view text, std::string& error) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  elcano::Error first = elcano::Error::success;
  for (const elcano::Generation generation : {elcano::Generation::b, elcano::Generation::d}) {
    LinkCounters counters;
    elcano::Decoder<256> reader(generation, counters);
    DecodeStatus status = DecodeStatus::more;
    for (const char c : text) {
      status = reader.feed(static_cast<std::uint8_t>(c));
      if (status != DecodeStatus::more) break;
    }
    if (status == DecodeStatus::more) status = reader.feed('\n');
    if (status == DecodeStatus::frame) return reader.frame();
    if (first == elcano::Error::success) {
      first = status == DecodeStatus::error ? reader.error() : elcano::Error::bad_lcurly;
    }
  }
  error = std::string("not an Elcano message (") + elcano::describe(first) +
          "): expected e.g. D{s 50}{a 25}, S{s 1}{a 2}{b 3}{p 4,5}, G{n 1}{p 0,0}{b 90}";
  return std::nullopt;
}

std::string format_elcano(const elcano::Message& message, elcano::Generation generation) {
  std::uint8_t buffer[160];
  const Result<std::size_t> written = elcano::encode_message(message, generation, MutableByteView(buffer));
  if (!written.ok()) return "?";
  std::size_t size = written.value();
  while (size > 0 && (buffer[size - 1] == '\n' || buffer[size - 1] == '\r')) --size;
  return std::string(reinterpret_cast<const char*>(buffer), size);
}

nlohmann::ordered_json elcano_json(const elcano::Message& message) {
  nlohmann::ordered_json object = {{"type", elcano::to_string(message.type)}};
  const std::pair<const char*, std::int32_t> fields[] = {
      {"n", message.number},  {"s", message.speed},       {"a", message.angle},   {"o", message.obstacle},
      {"b", message.bearing}, {"r", message.probability}, {"east", message.east}, {"north", message.north}};
  for (const auto& [name, value] : fields) {
    if (value != elcano::kUnset) object[name] = value;
  }
  return object;
}

std::optional<elcano::TypeSet> parse_elcano_types(std::string_view text) {
  elcano::TypeSet set;
  if (text.empty() || text == "none") return set;
  while (!text.empty()) {
    const std::size_t comma = text.find(',');
    const std::string_view word = text.substr(0, comma);
    elcano::Type type;
    if (!elcano::type_from_name(ByteView::from_chars(word.data(), word.size()), type)) {
      return std::nullopt;
    }
    set = set.with(type);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return set;
}

ShellLine ring_event_line(const elcano::Event& event, elcano::Generation generation) {
  namespace ev = elcano::events;
  if (const auto* undeliverable = std::get_if<ev::Undeliverable>(&event)) {
    const std::string text = format_elcano(undeliverable->message, generation);
    return {"undeliverable " + text + " (came back round the ring: nobody captured it)",
            {{"event", "undeliverable"}, {"text", text}, {"message", elcano_json(undeliverable->message)}}};
  }
  if (const auto* dropped = std::get_if<ev::InputDropped>(&event)) {
    return {std::string("read error: ") + elcano::describe(dropped->error),
            {{"event", "read_error"}, {"reason", elcano::describe(dropped->error)}}};
  }
  if (const auto* forward = std::get_if<ev::ForwardDropped>(&event)) {
    const std::string text = format_elcano(forward->message, generation);
    return {"forward dropped " + text + " (output queue full)", {{"event", "forward_dropped"}, {"text", text}}};
  }
  if (const auto* overflow = std::get_if<ev::ReceiveOverflow>(&event)) {
    const std::string text = format_elcano(overflow->message, generation);
    return {"receive overflow, dropped " + text, {{"event", "receive_overflow"}, {"text", text}}};
  }
  const auto& failed = std::get<ev::LinkFailed>(event);
  return {"link failed: " + failed.error.message(), {{"event", "link_failed"}, {"message", failed.error.message()}}};
}

ShellLine captured_line(const elcano::Message& message, elcano::Generation generation) {
  const std::string text = format_elcano(message, generation);
  return {"captured " + text, {{"event", "captured"}, {"text", text}, {"message", elcano_json(message)}}};
}

namespace {

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

std::unique_ptr<MonitorDecoder> make_elcano_monitor_decoder(const devices::DeviceConfig& config,
                                                            const DecoderRole& role, Millis now) {
  const auto& options = config.options.get<elcano::DeviceOptions>();
  if (role.ring_node) return std::make_unique<ElcanoRingNodeDecoder>(options, now);
  return std::make_unique<ElcanoReaderDecoder>(options.generation);
}

}  // namespace tether::cli
