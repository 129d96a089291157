// Test harness for the Elcano ring interop tests: elcano-node images on virtual Unos wired in a lockstep
// ring, with a RingNode in the test playing the host's place (host TX -> board 1 -> ... -> board N -> host
// RX). Deterministic: the group advances with run_for() on the test's thread and the host reacts between
// steps (1 ms by default, the resolution of the host's millisecond clock).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tether/elcano/message.hpp"
#include "tether/elcano/node/config.hpp"
#include "tether/elcano/node/stats.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::elcano::interop {

/// TypeSet::bits() of each type, for NodeConfig::capture_bits.
inline constexpr std::uint8_t kDriveBit = 1, kSensorBit = 2, kGoalBit = 4, kSegmentBit = 8;

/// build/firmware/elcano-node.elf.
std::filesystem::path node_image();

/// A node configuration at 115200 with an output link paced for a next node that keeps up.
node::NodeConfig node_config(std::uint8_t number, std::uint8_t capture_bits, std::uint8_t behaviour_bits,
                             Generation generation = Generation::b);

/// The reference three-node ring: board 1 captures goals and answers segments; board 2 captures sensors
/// and segments and answers drives; board 3 captures drives, drives D9/D10 and reports a sensor back.
std::vector<node::NodeConfig> reference_ring(Generation generation = Generation::b);

/// The message in generation B text (for failure messages).
std::string describe(const Message& message);

/// An event of the host's RingNode and when it happened.
struct HostEvent {
  RingEvent event;  ///< What the host node reported.
  Millis at = 0;    ///< Simulated ms.
};

/// How a ring is built.
struct RingOptions {
  /// One EEPROM configuration per board, in ring order.
  std::vector<node::NodeConfig> boards;
  /// The image of each board, in ring order (missing or empty entries: elcano-node); e.g. an Arduino
  /// sketch in a ring of elcano-node boards. Its EEPROM gets the board's configuration all the same.
  std::vector<std::filesystem::path> images;
  /// Write the configurations into the boards' EEPROM (false: erased EEPROM, build-time defaults).
  bool write_eeprom = true;
  /// The host's node.
  Generation generation = Generation::b;
  TypeSet host_capture = TypeSet::of(Type::sensor);  ///< What the host consumes.
  session::LinkPacing host_pacing{};                 ///< The host -> board 1 link.
  std::uint64_t seed = 0;                            ///< Boards' fault and power-up seeds (mixed per board).
};

/// Host node type (the same template the firmware runs, with the firmware's sizes).
using HostNode = RingNode<96, 256, 4>;

/// A ring of elcano-node boards and the host's node (see the file comment).
class Ring {
 public:
  /// Creates and wires the boards (not run yet).
  explicit Ring(RingOptions options);
  ~Ring();
  Ring(const Ring&) = delete;
  Ring& operator=(const Ring&) = delete;

  /// Advances the ring by `duration` in steps of `step`; the host reads, polls and writes after each.
  void run(transports::SimDuration duration, transports::SimDuration step = std::chrono::milliseconds(1));
  /// Runs until `done()` (checked after each step) or `limit`; returns done().
  bool run_until(const std::function<bool()>& done, transports::SimDuration limit,
                 transports::SimDuration step = std::chrono::milliseconds(1));
  /// Simulated time in ms (the host's clock).
  Millis now() const;

  /// The host originates `message` (written at once, as paced).
  Status send(const Message& message);
  /// Called for every host event (after it is recorded).
  std::function<void(const HostEvent&)> on_event;
  /// Every host event so far.
  const std::vector<HostEvent>& events() const { return events_; }
  /// Host events of `kind` (and of `type`, for events carrying a message).
  std::size_t count(RingEvent::Kind kind, Type type) const;
  /// Host events of `kind`.
  std::size_t count(RingEvent::Kind kind) const;

  /// The host's node and counters.
  HostNode& host() { return *host_; }
  const RingCounters& host_ring() const { return host_ring_; }
  const LinkCounters& host_link() const { return host_link_; }
  LinkCounters& host_link() { return host_link_; }
  /// Bytes the host wrote to board 1 / read from the last board.
  std::uint64_t bytes_sent() const { return bytes_sent_; }
  std::uint64_t bytes_received() const { return bytes_received_; }

  /// Board `index` (0-based) and the group.
  transports::VirtualUno& board(std::size_t index) { return *boards_.at(index); }
  std::size_t size() const { return boards_.size(); }
  transports::VirtualUnoGroup& group() { return group_; }
  /// Board `index`'s published NodeStats (read through its seqlock; may advance the ring by microseconds).
  /// Throws when the image has no stats symbol or the firmware has not initialised it.
  node::NodeStats stats(std::size_t index);

 private:
  void step(transports::SimDuration duration);
  void dispatch(const RingEvent& event, Millis at);
  void pump(Millis at);

  RingOptions options_;
  std::vector<std::unique_ptr<transports::VirtualUno>> boards_;
  transports::VirtualUnoGroup group_;
  LinkCounters host_link_;
  RingCounters host_ring_;
  std::unique_ptr<HostNode> host_;
  std::deque<std::uint8_t> inbox_;  // bytes from the last board, filled by its output handler (this thread)
  std::vector<HostEvent> events_;
  std::uint64_t bytes_sent_ = 0;
  std::uint64_t bytes_received_ = 0;
};

}  // namespace tether::elcano::interop
