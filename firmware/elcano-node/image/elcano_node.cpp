// The `elcano-node` image: one node of an Elcano ring on an Arduino Uno (firmware/elcano-node/README.md).
//
// UART0 (8N1, default 115200) is the ring: bytes from the previous node in, bytes to the next node out. A
// RingNode (codecs/elcano) consumes the configured types, forwards the rest without re-serialising, drops
// its own messages coming back, and paces its output for the next node. Behaviours answer what the node
// captures and drive servos on D9/D10. Nothing else is ever written to the UART: no banner, no log (a
// ring node must not inject bytes). A reset simply restarts the node: the ring needs no handshake. A
// reset in the middle of sending a message leaves the next node holding half a message; the first header
// after the reboot ends it (dropped, counted) and starts the next message (the reader's rule 3).
//
// Buffers: RX ring 64 bytes like the Arduino core's, so a node whose loop is busy (loop_period) overflows
// exactly when a real one would, unless its upstream paces for it; TX ring 64 bytes, filled only with
// what fits (never blocks); RingNode output queue 256 bytes (a burst of ~8 messages).
#include <avr/eeprom.h>
#include <avr/pgmspace.h>

#include "tether/core/bytes.hpp"
#include "tether/core/execution_witness.hpp"
#include "tether/elcano/node/behaviour.hpp"
#include "tether/elcano/node/config.hpp"
#include "tether/firmware/servo_timer1.hpp"
#include "tether/elcano/node/stats.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/firmware/runtime.hpp"

namespace node = tether::elcano::node;
namespace servo_timer1 = tether::firmware::servo_timer1;

extern "C" {
/// Counters and effective configuration for tests and debuggers (layout: tether/elcano/node/stats.hpp).
__attribute__((used, externally_visible)) node::NodeStats elcano_node_stats;
}

namespace {

using Serial = tether::firmware::Uart0<64, 64>;
using Node = tether::elcano::RingNode<96, 256, 4>;

// Build-time defaults (firmware/elcano-node/CMakeLists.txt), used unless the EEPROM holds a valid block.
// Checked here with the rules an EEPROM block must pass (config_is_valid).
static_assert(TETHER_ELCANO_NODE_BAUD >= node::kMinBaud && TETHER_ELCANO_NODE_BAUD <= node::kMaxBaud,
              "TETHER_ELCANO_NODE_BAUD out of range");
static_assert(TETHER_ELCANO_NODE_CAPTURE <= 0x0Fu, "TETHER_ELCANO_NODE_CAPTURE: drive 1, sensor 2, goal 4, segment 8");
static_assert(TETHER_ELCANO_NODE_BEHAVIOUR <= node::kAllBehaviours, "TETHER_ELCANO_NODE_BEHAVIOUR: unknown bits");
static_assert(TETHER_ELCANO_NODE_NEXT_RX_BUFFER >= 2u && TETHER_ELCANO_NODE_NEXT_RX_BUFFER <= 0xFFFFu,
              "TETHER_ELCANO_NODE_NEXT_RX_BUFFER out of range");
static_assert(TETHER_ELCANO_NODE_NEXT_POLL_MS <= 0xFFFFu && TETHER_ELCANO_NODE_LOOP_PERIOD_MS <= 0xFFFFu &&
                  TETHER_ELCANO_NODE_NUMBER <= 0xFFu,
              "elcano-node defaults out of range");

node::NodeConfig build_defaults() {
  node::NodeConfig config;
  config.generation = TETHER_ELCANO_NODE_GENERATION == 'D' ? tether::elcano::Generation::d : tether::elcano::Generation::b;
  config.baud = TETHER_ELCANO_NODE_BAUD;
  config.capture_bits = TETHER_ELCANO_NODE_CAPTURE;
  config.behaviour_bits = TETHER_ELCANO_NODE_BEHAVIOUR;
  config.next_receiver_buffer = TETHER_ELCANO_NODE_NEXT_RX_BUFFER;
  config.next_poll_interval = TETHER_ELCANO_NODE_NEXT_POLL_MS;
  config.loop_period = TETHER_ELCANO_NODE_LOOP_PERIOD_MS;
  config.node_number = TETHER_ELCANO_NODE_NUMBER;
  return config;
}

node::ConfigSource g_source = node::ConfigSource::defaults;

node::NodeConfig load_config() {
  node::NodeConfig config = build_defaults();
  uint8_t block[node::kConfigBlockSize];
  // A valid block uploaded with the image (through a bootloader that cannot write EEPROM) becomes the EEPROM
  // block; eeprom_update_block writes only the bytes that differ, so later boots cost no EEPROM wear.
  memcpy_P(block, reinterpret_cast<const void*>(node::kUploadedConfigAddress), sizeof block);
  node::NodeConfig uploaded;
  if (node::decode_config(block, uploaded) == node::ConfigSource::eeprom) {
    eeprom_update_block(block, reinterpret_cast<void*>(node::kConfigAddress), sizeof block);
  }
  eeprom_read_block(block, reinterpret_cast<const void*>(node::kConfigAddress), sizeof block);
  g_source = node::decode_config(block, config);
  return config;
}

tether::elcano::RingNodeConfig ring_config(const node::NodeConfig& config) {
  tether::elcano::RingNodeConfig ring;
  ring.generation = config.generation;
  ring.capture = tether::elcano::TypeSet::from_bits(config.capture_bits);
  // A node that reads every N ms sees a message arrive in pieces up to N ms apart: give it two periods more
  // than the default before a partial message counts as stalled.
  ring.partial_message_timeout = ring.partial_message_timeout + 2u * static_cast<tether::Duration>(config.loop_period);
  ring.pacing.baud = config.baud;
  ring.pacing.receiver_buffer = config.next_receiver_buffer;
  ring.pacing.receiver_poll_interval = config.next_poll_interval;
  return ring;
}

// Static construction, in this order: the configuration (read from EEPROM before main), then the node.
const node::NodeConfig g_config = load_config();
Node g_node(ring_config(g_config), 0, elcano_node_stats.link, elcano_node_stats.ring);
node::Behaviour g_behaviour(g_config.behaviour_bits);

// Seqlock around counter updates (stats.hpp): the barriers keep the compiler from moving the counters'
// stores across the volatile sequence stores.
void begin_update() {
  volatile uint8_t* sequence = &elcano_node_stats.sequence;
  *sequence = static_cast<uint8_t>(*sequence + 1u);
  tether::firmware::compiler_barrier();
}
void end_update() {
  tether::firmware::compiler_barrier();
  volatile uint8_t* sequence = &elcano_node_stats.sequence;
  *sequence = static_cast<uint8_t>(*sequence + 1u);
}

void publish_config() {
  node::NodeStats& stats = elcano_node_stats;
  stats.baud = g_config.baud;
  stats.loop_period = g_config.loop_period;
  stats.next_receiver_buffer = g_config.next_receiver_buffer;
  stats.next_poll_interval = g_config.next_poll_interval;
  stats.layout = node::kStatsLayout;
  stats.config_source = static_cast<uint8_t>(g_source);
  stats.node_number = g_config.node_number;
  stats.generation = g_config.generation == tether::elcano::Generation::d ? 'D' : 'B';
  stats.capture_bits = g_config.capture_bits;
  stats.behaviour_bits = g_config.behaviour_bits;
  stats.reset_cause = tether::firmware::reset_cause();
  tether::firmware::compiler_barrier();
  for (uint8_t i = 0; i < 4; ++i) stats.magic[i] = node::kStatsMagic[i];  // last: the rest is valid now
}

void handle(tether::elcano::RingEvent::Kind kind, tether::Millis now) {
  if (kind != tether::elcano::RingEvent::Kind::captured) return;
  const node::Reaction reaction = g_behaviour.on_captured(g_node.message());
  node::NodeStats& stats = elcano_node_stats;
  if (reaction.drive) {
    servo_timer1::write(servo_timer1::Output::d9, reaction.throttle_us);
    servo_timer1::write(servo_timer1::Output::d10, reaction.steering_us);
    stats.throttle_us = reaction.throttle_us;
    stats.steering_us = reaction.steering_us;
    ++stats.drives_applied;
    // Witness key: the drive's raw speed and angle (tether/core/execution_witness.hpp; read by `tether demo`).
    tether::witness_executed(tether::witness_key(static_cast<uint16_t>(g_node.message().speed),
                                                 static_cast<uint16_t>(g_node.message().angle)));
  }
  if (reaction.answer) {
    if (g_node.originate(reaction.message, now) == tether::Status::ok) {
      ++stats.answers;
    } else {
      ++stats.answers_refused;
    }
  }
}

// Hands paced output to the TX ring, only as much as fits: the loop never blocks on the UART.
void pump_output(tether::Millis now) {
  uint8_t chunk[Serial::kTxCapacity];
  const uint8_t room = Serial::available_for_write();
  if (room == 0 || g_node.pending_output() == 0) return;
  const size_t count = g_node.take_output(tether::MutableByteView(chunk, room), now);
  if (count != 0) Serial::try_write(tether::ByteView(chunk, count));
}

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(g_config.baud);
  publish_config();
  if ((g_config.behaviour_bits & node::kDriveServos) != 0) {
    servo_timer1::attach(servo_timer1::Output::d9, node::kNeutralPulseUs);   // throttle
    servo_timer1::attach(servo_timer1::Output::d10, node::kNeutralPulseUs);  // steering
    elcano_node_stats.throttle_us = node::kNeutralPulseUs;
    elcano_node_stats.steering_us = node::kNeutralPulseUs;
  }
  const uint16_t period = g_config.loop_period;
  tether::Millis next_read = tether::firmware::millis();
  uint8_t chunk[16];
  for (;;) {
    const tether::Millis now = tether::firmware::millis();
    begin_update();
    // A node with a loop period models a reference node whose loop() does other work: its RX ring is
    // emptied only once per period, so bytes beyond 64 in between are lost (and counted).
    if (period == 0 || tether::tick_reached(now, next_read)) {
      // On a fixed grid, so the gap between reads is the period itself (what the upstream's pacing assumes);
      // a loop that fell a whole period behind starts a new grid instead of reading twice in a row.
      next_read = static_cast<tether::Millis>(next_read + period);
      if (tether::tick_reached(now, next_read)) next_read = static_cast<tether::Millis>(now + period);
      const uint8_t waiting = Serial::available();  // how close the ring came to overflowing
      if (waiting > elcano_node_stats.rx_peak) elcano_node_stats.rx_peak = waiting;
      for (;;) {
        const size_t count = Serial::read(tether::MutableByteView(chunk));
        if (count == 0) break;
        // The whole chunk through the reader's span loop; each event handled where it happened. A pointer
        // walks the chunk: rest.subview() (out of line, with its bounds clamp) and the view kept in memory cost
        // the bench-codecs read loop, the same loop, ~90 cycles a message.
        const uint8_t* const end = chunk + count;
        for (const uint8_t* next = chunk; next != end;) {
          size_t used = 0;
          handle(g_node.consume(tether::ByteView(next, static_cast<size_t>(end - next)), now, used), now);
          next += used;
        }
      }
    }
    while (g_node.poll(now).kind != tether::elcano::RingEvent::Kind::none) {
    }
    pump_output(now);
    const tether::firmware::UartCounters uart = Serial::counters();
    elcano_node_stats.uart_rx_overflows = uart.rx_overflows;
    elcano_node_stats.uart_framing_errors = uart.framing_errors;
    elcano_node_stats.uart_data_overruns = uart.data_overruns;
    end_update();
    // Sleep until the next interrupt (a byte, a sent byte, the 1 ms tick), unless bytes are waiting for a
    // node that reads continuously.
    tether::firmware::idle_unless([period] { return period == 0 && Serial::available() != 0; });
  }
}
