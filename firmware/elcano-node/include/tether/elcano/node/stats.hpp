/// @file stats.hpp
/// The `elcano-node` image's counters and effective configuration, kept in RAM where a test can read them
/// without touching the ring: the global `elcano_node_stats` (C linkage, so its ELF symbol is that name).
/// A host finds its address in the image's symbol table (`VirtualUno::symbol`) and copies the bytes
/// (`VirtualUno::read_memory`).
///
/// Layout: no padding on either compiler (4-byte fields first, then 2-byte, then 1-byte, explicit tail
/// padding) and both targets are little-endian, so the host copies the bytes straight into this struct;
/// the size is checked on both sides. `magic` says the firmware has initialised it (it is zero before).
/// `sequence` is odd while the main loop updates counters: a reader that finds it odd, or changed between
/// two reads, lets the board run a few microseconds and reads again (a seqlock).
#pragma once

#include <stdint.h>

#include "tether/core/counters.hpp"
#include "tether/elcano/ring_node.hpp"

namespace tether {
namespace elcano {
namespace node {

/// `NodeStats::magic` once the firmware is up.
constexpr uint8_t kStatsMagic[4] = {'E', 'L', 'N', 'S'};
/// `NodeStats::layout` of this header (bump when fields move; the counter structs' own growth is covered by
/// building the image and its readers from the same headers).
constexpr uint8_t kStatsLayout = 1;
/// Name of the global (C linkage) in the image.
#define TETHER_ELCANO_NODE_STATS_SYMBOL "elcano_node_stats"

/// The published state of one node.
struct NodeStats {
  uint8_t magic[4];          ///< kStatsMagic once initialised.
  RingCounters ring;         ///< The RingNode's counters (captured, forwarded, originated, ...).
  LinkCounters link;         ///< Reader counters (frames_ok, crc_errors, framing_errors, partial_timeouts, ...).
  uint32_t uart_rx_overflows;    ///< Bytes lost because the 64-byte RX ring was full (Uart0 counters).
  uint32_t uart_framing_errors;  ///< Bytes with a bad stop bit.
  uint32_t uart_data_overruns;   ///< Bytes the hardware lost (RX interrupt late).
  uint32_t answers;          ///< Answers originated (goal->segment, ->drive, drive->sensor).
  uint32_t answers_refused;  ///< Answers the RingNode refused (output queue full).
  uint32_t drives_applied;   ///< Captured drives put on the servos.
  uint32_t baud;             ///< Effective configuration: UART rate.
  uint16_t loop_period;           ///< Effective configuration: RX handled every N ms (0: continuously).
  uint16_t next_receiver_buffer;  ///< Effective configuration: pacing, next node's buffer.
  uint16_t next_poll_interval;    ///< Effective configuration: pacing, next node's poll interval (ms).
  uint16_t throttle_us;      ///< Last D9 pulse set (0: servos off).
  uint16_t steering_us;      ///< Last D10 pulse set (0: servos off).
  uint8_t layout;            ///< kStatsLayout.
  uint8_t sequence;          ///< Odd while the counters are being updated (see the file comment).
  uint8_t config_source;     ///< ConfigSource.
  uint8_t node_number;       ///< Effective configuration: node number.
  uint8_t generation;        ///< Effective configuration: 'B' or 'D'.
  uint8_t capture_bits;      ///< Effective configuration: TypeSet bits.
  uint8_t behaviour_bits;    ///< Effective configuration: behaviour bits.
  uint8_t reset_cause;       ///< MCUSR at boot (tether/firmware/reset.hpp).
  uint8_t rx_peak;           ///< Most bytes ever found waiting in the RX ring when the node came to read it.
  uint8_t padding;           ///< Keeps the size a multiple of 4 on the host too.
};

// No padding anywhere: the same bytes on the AVR (1-byte alignment) and the host (natural alignment).
static_assert(sizeof(RingCounters) % 4 == 0 && sizeof(LinkCounters) % 4 == 0, "counter structs hold uint32_t only");
static_assert(sizeof(NodeStats) == 4 + sizeof(RingCounters) + sizeof(LinkCounters) + 7 * 4 + 5 * 2 + 10,
              "NodeStats must have the same layout on the AVR and the host");

}  // namespace node
}  // namespace elcano
}  // namespace tether
