/// @file config.hpp
/// Configuration of the `elcano-node` image and its EEPROM block (layout in firmware/elcano-node/README.md).
///
/// A node boots with build-time defaults (CMake cache variables, see the README) unless EEPROM address 0
/// holds a valid block: magic `EN`, version 1, sane values and a CRC-8/SMBUS over the block. Anything else
/// (an erased EEPROM, a block of another version, a bit flipped in storage) is ignored whole: a node never
/// runs on half a configuration. Portable (the image and the host tests share it), header-only.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/crc.hpp"
#include "tether/elcano/message.hpp"

namespace tether {
namespace elcano {
namespace node {

/// Behaviour bit: answer a captured goal with a segment.
constexpr uint8_t kAnswerGoalWithSegment = 0x01;
/// Behaviour bit: answer a captured segment with a drive.
constexpr uint8_t kAnswerSegmentWithDrive = 0x02;
/// Behaviour bit: answer a captured sensor with a drive.
constexpr uint8_t kAnswerSensorWithDrive = 0x04;
/// Behaviour bit: act on a captured drive (servo pulses on D9 throttle and D10 steering).
constexpr uint8_t kDriveServos = 0x08;
/// Behaviour bit: report a captured drive to the next node as a sensor message.
constexpr uint8_t kReportDriveAsSensor = 0x10;
/// Every behaviour bit defined so far; a block with others set is rejected.
constexpr uint8_t kAllBehaviours = 0x1F;

/// What a node is and does.
struct NodeConfig {
  Generation generation = Generation::b;  ///< Wire generation of the ring.
  uint32_t baud = 115200;                 ///< UART0 rate (8N1), both directions.
  uint8_t capture_bits = 0;               ///< Types consumed, as TypeSet::bits() (drive 1 sensor 2 goal 4 segment 8).
  uint8_t behaviour_bits = 0;             ///< k* behaviour bits above.
  uint16_t next_receiver_buffer = 64;     ///< Pacing of the output link: the next node's receive buffer.
  uint16_t next_poll_interval = 0;        ///< Pacing: longest gap (ms) between the next node's reads (0: keeps up).
  uint16_t loop_period = 0;               ///< This node reads its RX ring every N ms (0: continuously).
  uint8_t node_number = 0;                ///< Free label (diagnostics).
};

/// EEPROM address of the block.
constexpr uint16_t kConfigAddress = 0;
/// Flash address of a block uploaded with the image (`tether flash --eeprom`): the first bytes of the last
/// 128-byte page below optiboot's boot section. Optiboot writes flash only, never EEPROM, so a block sent
/// with the image is copied into EEPROM by the node at boot when valid (erased flash, 0xFF, has no magic).
constexpr uint16_t kUploadedConfigAddress = 0x7D80;
/// Layout version this firmware reads.
constexpr uint8_t kConfigVersion = 1;
/// Bytes in the block, CRC included.
constexpr size_t kConfigBlockSize = 18;
/// Slowest baud rate accepted.
constexpr uint32_t kMinBaud = 1200;
/// Fastest baud rate accepted (the Uno's UART does 1 Mbit/s at U2X, UBRR 1).
constexpr uint32_t kMaxBaud = 1000000;

/// Why a node runs the configuration it runs (published in NodeStats::config_source).
enum class ConfigSource : uint8_t {
  defaults = 0,        ///< No block (no magic at address 0): build-time defaults.
  eeprom = 1,          ///< The EEPROM block.
  rejected_block = 2,  ///< A block with the magic but a bad version, CRC or value: build-time defaults.
};

/// True when every field is usable.
inline bool config_is_valid(const NodeConfig& config) {
  if (config.generation != Generation::b && config.generation != Generation::d) return false;
  if (config.baud < kMinBaud || config.baud > kMaxBaud) return false;
  if ((config.capture_bits & 0xF0u) != 0 || (config.behaviour_bits & static_cast<uint8_t>(~kAllBehaviours)) != 0) {
    return false;
  }
  return config.next_receiver_buffer >= 2;
}

namespace detail {
inline void put16(uint8_t* at, uint16_t value) {
  at[0] = static_cast<uint8_t>(value);
  at[1] = static_cast<uint8_t>(value >> 8);
}
inline uint16_t get16(const uint8_t* at) { return static_cast<uint16_t>(at[0] | (at[1] << 8)); }
}  // namespace detail

/// Writes `config` as the EEPROM block (little-endian fields, CRC-8/SMBUS of bytes 0..16 in byte 17).
inline void encode_config(const NodeConfig& config, uint8_t (&block)[kConfigBlockSize]) {
  block[0] = 'E';
  block[1] = 'N';
  block[2] = kConfigVersion;
  block[3] = config.generation == Generation::d ? 'D' : 'B';
  for (uint8_t i = 0; i < 4; ++i) block[4 + i] = static_cast<uint8_t>(config.baud >> (8u * i));
  block[8] = config.capture_bits;
  block[9] = config.behaviour_bits;
  detail::put16(block + 10, config.next_receiver_buffer);
  detail::put16(block + 12, config.next_poll_interval);
  detail::put16(block + 14, config.loop_period);
  block[16] = config.node_number;
  block[17] = Crc8Smbus::compute(ByteView(block, kConfigBlockSize - 1));
}

/// Reads a block into `config` (left untouched unless the answer is `eeprom`).
inline ConfigSource decode_config(const uint8_t (&block)[kConfigBlockSize], NodeConfig& config) {
  if (block[0] != 'E' || block[1] != 'N') return ConfigSource::defaults;
  if (block[2] != kConfigVersion || block[17] != Crc8Smbus::compute(ByteView(block, kConfigBlockSize - 1))) {
    return ConfigSource::rejected_block;
  }
  if (block[3] != 'B' && block[3] != 'D') return ConfigSource::rejected_block;
  NodeConfig read;
  read.generation = block[3] == 'D' ? Generation::d : Generation::b;
  read.baud = 0;
  for (uint8_t i = 0; i < 4; ++i) read.baud |= static_cast<uint32_t>(block[4 + i]) << (8u * i);
  read.capture_bits = block[8];
  read.behaviour_bits = block[9];
  read.next_receiver_buffer = detail::get16(block + 10);
  read.next_poll_interval = detail::get16(block + 12);
  read.loop_period = detail::get16(block + 14);
  read.node_number = block[16];
  if (!config_is_valid(read)) return ConfigSource::rejected_block;
  config = read;
  return ConfigSource::eeprom;
}

}  // namespace node
}  // namespace elcano
}  // namespace tether
