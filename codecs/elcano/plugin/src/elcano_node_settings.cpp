// An elcano-node's settings: read from JSON, encoded into the image's EEPROM block (node_settings.hpp).
#include "tether/elcano/node_settings.hpp"

#include <iterator>

#include <nlohmann/json.hpp>

#include "tether/devices/config.hpp"
#include "tether/elcano/node/config.hpp"
#include "tether/elcano/plugin.hpp"

namespace tether::elcano {

namespace {

// Behaviour names, bit i = 1 << i (the elcano-node image's k* behaviour bits).
const devices::Names kNodeBehaviours = {"answer_goal_with_segment", "answer_segment_with_drive",
                                        "answer_sensor_with_drive", "drive_servos", "report_drive_as_sensor"};

// The keys of a settings object; a node file adds the ring's `generation` and `baud`.
const devices::Names kNodeSettingKeys = {"capture",        "behaviours", "next_receiver_buffer", "next_poll_interval_ms",
                                         "loop_period_ms", "node_number"};

RingNodeSettings read_settings(const devices::JsonObject& settings, std::uint8_t default_node_number) {
  RingNodeSettings node_settings;
  node_settings.node_number = default_node_number;
  if (auto c = settings.optional("capture")) node_settings.capture = read_message_types(*c);
  if (auto b = settings.optional("behaviours")) {
    if (!b->value.is_array()) b->expected("an array of behaviours (" + devices::join_names(kNodeBehaviours) + ")");
    devices::for_each_element(*b, [&](const devices::JsonNode& element, std::size_t) {
      const auto bit = static_cast<std::uint8_t>(1u << devices::read_choice(element, "behaviour", kNodeBehaviours));
      if ((node_settings.behaviour_bits & bit) != 0) {
        devices::fail_config(element.path, "behaviour " + element.value.dump() + " is listed twice");
      }
      node_settings.behaviour_bits = static_cast<std::uint8_t>(node_settings.behaviour_bits | bit);
    });
  }
  if (auto n = settings.optional("next_receiver_buffer")) {
    node_settings.next_receiver_buffer = static_cast<std::uint16_t>(devices::read_unsigned(*n, 2, 65535));
  }
  if (auto n = settings.optional("next_poll_interval_ms")) {
    node_settings.next_poll_interval = static_cast<std::uint16_t>(devices::read_unsigned(*n, 0, 65535));
  }
  if (auto n = settings.optional("loop_period_ms")) {
    node_settings.loop_period = static_cast<std::uint16_t>(devices::read_unsigned(*n, 0, 65535));
  }
  if (auto n = settings.optional("node_number")) {
    node_settings.node_number = static_cast<std::uint8_t>(devices::read_unsigned(*n, 0, 255));
  }
  return node_settings;
}

}  // namespace

RingNodeSettings read_node_settings(const devices::JsonNode& node, std::uint8_t default_node_number) {
  const devices::JsonObject settings(node);
  settings.allow_only(kNodeSettingKeys);
  return read_settings(settings, default_node_number);
}

NodeFile parse_node_file(std::string_view json_text) {
  const nlohmann::json document = devices::parse_json_text(json_text);
  const devices::JsonNode root{document, ""};
  if (!document.is_object()) root.expected("an object of node settings");
  const devices::JsonObject object(root);
  devices::Names keys = kNodeSettingKeys;
  keys.push_back("generation");
  keys.push_back("baud");
  object.allow_only(keys);
  NodeFile file;
  file.settings = read_settings(object, 0);
  if (auto v = object.optional("generation")) {
    file.generation = devices::read_choice(*v, "generation", {"B", "D"}) == 0 ? Generation::b : Generation::d;
  }
  // The node's own range: a baud it would refuse is an error at its key here, not a nameless one when the
  // block is encoded (found by fuzzing).
  if (auto v = object.optional("baud")) {
    file.baud = static_cast<std::uint32_t>(devices::read_unsigned(*v, node::kMinBaud, node::kMaxBaud));
  }
  return file;
}

std::uint32_t node_upload_address() { return node::kUploadedConfigAddress; }

std::vector<std::uint8_t> encode_node_block(const RingNodeSettings& settings, Generation generation,
                                            std::uint32_t baud, const std::string& path) {
  node::NodeConfig config;
  config.generation = generation;
  config.baud = baud;
  config.capture_bits = settings.capture.bits();
  config.behaviour_bits = settings.behaviour_bits;
  config.next_receiver_buffer = settings.next_receiver_buffer;
  config.next_poll_interval = settings.next_poll_interval;
  config.loop_period = settings.loop_period;
  config.node_number = settings.node_number;
  if (!node::config_is_valid(config)) {
    devices::fail_config(path, "not a valid elcano-node configuration (baud " + std::to_string(config.baud) +
                                   " outside " + std::to_string(node::kMinBaud) + ".." +
                                   std::to_string(node::kMaxBaud) +
                                   ", unknown behaviour bits, or a next receiver buffer under 2)");
  }
  std::uint8_t block[node::kConfigBlockSize];
  node::encode_config(config, block);
  return std::vector<std::uint8_t>(std::begin(block), std::end(block));
}

}  // namespace tether::elcano
