// The Elcano codec's plugin (plugin.hpp): an `elcano` device in a configuration and its ring client.
#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>

#include "tether/elcano/decoder.hpp"
#include "tether/elcano/node/config.hpp"
#include "tether/elcano/node_settings.hpp"
#include "tether/elcano/plugin.hpp"

namespace tether::elcano {

namespace {

// The codec's names (to_string), in the order of kElcanoTypeValues.
constexpr std::array<Type, 4> kElcanoTypeValues = {Type::drive, Type::sensor, Type::goal, Type::segment};
const devices::Names kElcanoTypes = {to_string(Type::drive), to_string(Type::sensor), to_string(Type::goal),
                                     to_string(Type::segment)};

}  // namespace

TypeSet read_message_types(const devices::JsonNode& node) {
  if (!node.value.is_array()) node.expected("an array of message types (" + devices::join_names(kElcanoTypes) + ")");
  TypeSet set;
  devices::for_each_element(node, [&](const devices::JsonNode& element, std::size_t) {
    const Type type = kElcanoTypeValues.at(devices::read_choice(element, "message type", kElcanoTypes));
    if (set.contains(type))
      devices::fail_config(element.path, "message type " + element.value.dump() + " is listed twice");
    set = set.with(type);
  });
  return set;
}

namespace {

DeviceOptions parse_elcano_options(const devices::JsonObject* object, const devices::TransportConfig& transport) {
  DeviceOptions options;
  if (const auto* serial = std::get_if<devices::SerialTransport>(&transport))
    options.pacing.baud = serial->options.baud;
  if (object == nullptr) return options;
  if (auto v = object->optional("generation")) {
    options.generation = devices::read_choice(*v, "generation", {"B", "D"}) == 0 ? Generation::b : Generation::d;
  }
  if (auto v = object->optional("capture")) options.capture = read_message_types(*v);
  if (auto v = object->optional("pacing")) {
    const devices::JsonObject pacing(*v);
    pacing.allow_only({"receiver_buffer", "receiver_poll_interval_ms"});
    if (auto p = pacing.optional("receiver_buffer")) {
      options.pacing.receiver_buffer = static_cast<std::uint16_t>(devices::read_unsigned(*p, 1, 65535));
    }
    if (auto p = pacing.optional("receiver_poll_interval_ms")) {
      options.pacing.receiver_poll_interval = static_cast<std::uint16_t>(devices::read_unsigned(*p, 0, 65535));
    }
  }
  devices::read_call_timing(*object, options.timing);
  return options;
}

devices::CodecOptions parse_elcano(const devices::OptionsContext& context) {
  const std::optional<devices::JsonObject> object = context.object();
  return parse_elcano_options(object ? &*object : nullptr, *context.transport);
}

void validate_elcano(const devices::CodecOptions& codec_options, const std::string& options_path) {
  const auto* options = codec_options.get_if<DeviceOptions>();
  if (options == nullptr) devices::fail_config(options_path, "codec elcano needs elcano::DeviceOptions");
  devices::check_call_timing(options_path, options->timing);
  if (options->pacing.baud == 0) devices::fail_config(options_path + ".pacing", "baud must be at least 1");
}

devices::DeviceClient open_elcano(std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
                                  std::shared_ptr<client::LinkClock> clock) {
  const auto& options = device.options.get<DeviceOptions>();
  Options client_options;
  client_options.node.generation = options.generation;
  client_options.node.capture = options.capture;
  client_options.node.pacing = options.pacing;
  client_options.timing = options.timing;
  client_options.clock = std::move(clock);
  return std::make_shared<RingClient>(std::move(stream), client_options);
}

// A virtual ring board's `"eeprom": {...}`: the node's block, on the device's generation and line speed.
std::vector<std::uint8_t> encode_ring_board(const devices::RingBoardContext& board) {
  static_assert(node::kConfigAddress == 0, "a ring board's EEPROM bytes start at address 0: the block's");
  const RingNodeSettings settings = read_node_settings(board.settings, static_cast<std::uint8_t>(board.index));
  const DeviceOptions* found = board.options != nullptr ? board.options->get_if<DeviceOptions>() : nullptr;
  const DeviceOptions options = found != nullptr ? *found : DeviceOptions();
  return encode_node_block(settings, options.generation, options.pacing.baud, board.settings.path);
}

// `tether flash --eeprom node.json`: the block goes into the flash page the node copies into EEPROM at boot.
devices::EepromUpload read_node_file(std::string_view text) {
  const NodeFile file = parse_node_file(text);
  return devices::EepromUpload{encode_node_block(file.settings, file.generation, file.baud), node_upload_address()};
}

}  // namespace

// Captures: a message is a line from its header (D, S, G or X) to `\n`; a header inside a message starts the
// next one (the sender reset), as in the decoder. Bounded generously: the decoder keeps 96 bytes without
// whitespace, a message with spaces is longer on the wire.
transports::CaptureFraming capture_framing(const devices::DeviceConfig&) {
  return [](bool) -> std::unique_ptr<transports::CaptureFramer> {
    return std::make_unique<transports::DelimitedFramer>(transports::DelimitedFraming::lines("DSGX", 1024));
  };
}

namespace {

// Playing a recorded Elcano device: ring messages carry no ids (and generation D's CRC covers only the
// message), so nothing is rewritten. A request is the message as a node forwards it (without whitespace);
// a message the recording lacks is answered with nothing, as a ring answers a message no node captures.
class ElcanoReplayer final : public transports::CaptureReplayer {
 public:
  explicit ElcanoReplayer(Generation generation) : generation_(generation) {}

  transports::ReplayRequest classify(std::span<const std::uint8_t> frame) override {
    LinkCounters counters;
    Decoder<> decoder(generation_, counters);
    for (const std::uint8_t byte : frame) {
      const DecodeStatus status = decoder.feed(byte);
      if (status == DecodeStatus::error) return {};
      if (status == DecodeStatus::frame) {
        const ByteView bytes = decoder.forward();
        return {transports::ReplayRequest::Kind::request,
                std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size())};
      }
    }
    return {};
  }
  void matched(std::span<const std::uint8_t>, std::span<const std::uint8_t>) override {}
  std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) override {
    return std::vector<std::uint8_t>(recorded.begin(), recorded.end());
  }
  std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t>) override { return {}; }

 private:
  Generation generation_;
};

}  // namespace

std::unique_ptr<transports::CaptureReplayer> capture_replayer(Generation generation) {
  return std::make_unique<ElcanoReplayer>(generation);
}

std::vector<devices::CodecRow> codec_rows() {
  devices::CodecRow row;
  row.codec = kCodec;
  row.name = "elcano";
  row.client_name = "elcano::RingClient";
  row.client_type = &typeid(RingClient);
  row.option_keys = {"generation", "capture", "pacing", "attempt_timeout_ms", "call_budget_ms", "max_attempts"};
  row.virtual_boards = devices::VirtualBoards::ring;
  row.ring_board_image = "elcano-node";
  row.ring_board_settings = encode_ring_board;
  row.eeprom_file.image = "elcano-node";
  row.eeprom_file.usage =
      "                  an elcano-node's configuration (capture, behaviours, pacing; the keys of a virtual\n"
      "                  ring board's `eeprom` in a rover configuration, plus `generation` and `baud`), uploaded\n"
      "                  with the image: optiboot cannot write EEPROM, so the block goes into the flash page at\n"
      "                  0x7D80 and the node copies it into EEPROM at boot (firmware/elcano-node/README.md)\n";
  row.eeprom_file.parse = read_node_file;
  row.parse_options = parse_elcano;
  row.validate = validate_elcano;
  row.open = open_elcano;
  row.capture_framing = capture_framing;
  row.capture_replay = [](const devices::DeviceConfig& device) {
    const auto* options = device.options.get_if<DeviceOptions>();
    return capture_replayer(options != nullptr ? options->generation : Generation::b);
  };
  row.capture_words = [](const devices::DeviceConfig& device) -> std::string {
    const auto* options = device.options.get_if<DeviceOptions>();
    if (options == nullptr) return {};
    return std::string("generation=") + (options->generation == Generation::d ? "D" : "B");
  };
  return {row};
}

}  // namespace tether::elcano
