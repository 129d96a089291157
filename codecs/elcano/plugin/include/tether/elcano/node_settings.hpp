/// @file node_settings.hpp
/// An `elcano-node` board's settings as a person writes them (JSON), and the configuration block the image
/// reads from EEPROM (firmware/elcano-node/README.md). Two places take them: a virtual ring board's
/// `"eeprom": {...}` in a rover configuration (the plugin's row encodes it when the configuration is parsed:
/// `devices::CodecRow::ring_board_settings`) and a node file of its own for `tether flash --eeprom node.json`
/// (`devices::CodecRow::eeprom_file`). Errors are `devices::ConfigError`s naming the key, as everywhere in a
/// configuration.
///
/// @code
///   const elcano::NodeFile file = elcano::parse_node_file(R"({"capture": ["drive"], "baud": 57600})");
///   const std::vector<std::uint8_t> block = elcano::encode_node_block(file.settings, file.generation, file.baud);
/// @endcode
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "tether/devices/json_reader.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"

namespace tether::elcano {

/// Node settings of an `elcano-node` board given as structure instead of raw EEPROM bytes (the image's
/// configuration block; generation and baud are the ring's: the device's `elcano::DeviceOptions`).
struct RingNodeSettings {
  TypeSet capture;                          ///< Message types the node consumes.
  std::uint8_t behaviour_bits = 0;          ///< What it does with them (`behaviours`: bit 0 answer_goal_with_segment,
                                            ///< 1 answer_segment_with_drive, 2 answer_sensor_with_drive,
                                            ///< 3 drive_servos, 4 report_drive_as_sensor).
  std::uint16_t next_receiver_buffer = 64;  ///< Pacing of its output: the next node's receive buffer (>= 2).
  std::uint16_t next_poll_interval = 0;     ///< Pacing: the next node's longest gap between reads (ms).
  std::uint16_t loop_period = 0;            ///< It reads its RX every N ms (0: continuously).
  std::uint8_t node_number = 0;             ///< Free label (diagnostics); default: its index in the ring.
};

/// One `elcano-node`'s configuration in a file of its own (`tether flash --eeprom node.json`): the keys of
/// a virtual ring board's `eeprom` settings plus the ring's `generation` and `baud`, which a rover
/// configuration takes from the device's options.
struct NodeFile {
  RingNodeSettings settings;                   ///< `node_number` defaults to 0.
  Generation generation = Generation::b;       ///< `"generation"`: `"B"` (default) or `"D"`.
  std::uint32_t baud = 115200;                 ///< `"baud"`: the ring's line speed.
};

/// A ring board's `eeprom` settings object (`capture`, `behaviours`, `next_receiver_buffer`,
/// `next_poll_interval_ms`, `loop_period_ms`, `node_number`); `node_number` defaults to
/// `default_node_number` (the board's index). Throws `devices::ConfigError` naming the key.
RingNodeSettings read_node_settings(const devices::JsonNode& node, std::uint8_t default_node_number);

/// Parses a node file's JSON text (comments allowed). Throws `devices::ConfigError` naming the key.
NodeFile parse_node_file(std::string_view json_text);

/// The `elcano-node` configuration block for `settings` on a ring of that generation and baud: the one
/// encoder, for virtual rings (written into EEPROM) and `tether flash --eeprom` alike. Throws
/// `devices::ConfigError` at `path` when the values do not make a block the node accepts.
std::vector<std::uint8_t> encode_node_block(const RingNodeSettings& settings, Generation generation,
                                            std::uint32_t baud, const std::string& path = "");

/// Flash address where an `elcano-node` image looks for a block uploaded with it (through a bootloader
/// that cannot write EEPROM) and copies it into EEPROM at boot.
std::uint32_t node_upload_address();

}  // namespace tether::elcano
