/// @file ring_node.hpp
/// One node of an Elcano ring, sans-I/O: bytes from the previous node in, events and bytes for the next
/// node out. The same class runs in the `elcano-node` firmware and in the host's `RingClient`.
///
/// The caller:
///   - feeds every received byte with `feed(byte, now)` and handles the event it returns;
///   - originates messages with `originate(message, now)`;
///   - hands `take_output(out, now)` bytes to its UART whenever it can (they are already paced);
///   - calls `poll(now)` at `next_wakeup(now)` (and whenever convenient) until it returns `none`.
///
/// Rules (each tested in codecs/elcano/tests/ring_node_test.cpp):
///   1. A complete message of a captured type is consumed (`captured`); any other message is queued for the
///      next node (`forwarded`) as the reader's `forward` bytes: byte-identical for generation D, whitespace-
///      stripped for generation B, like the reference. Messages leave whole and in arrival order.
///   2. Loop protection without touching the wire format: the node remembers the CRC-16 and length of the
///      (whitespace-stripped) bytes of each message it originates for `return_timeout`. A message that
///      matches one comes back from a trip round the ring: nobody captured it. It is dropped and reported
///      once as `undeliverable` (the reference let it circulate forever). A record that expires means the
///      message was consumed somewhere (or lost). Limits: a record is kept for `return_timeout` at most,
///      and when all `OriginSlots` are taken the oldest is overwritten (`origins_evicted`); another node
///      originating the very same bytes within that window would be taken for ours.
///   3. A partial message older than `partial_message_timeout` is dropped (`dropped`, `timed_out`): the node
///      never waits forever on half a message.
///   4. Output is paced (core/session/write_pacer.hpp) by the baud rate and the next node's receive buffer,
///      so a node never writes faster than the next one reads. A message that finds the output queue full
///      is dropped and reported (`dropped`, `queue_full`); `originate` answers `Status::busy` instead, so
///      the application sees the back-pressure. Forwarding has priority: `originate` leaves room for one
///      more message of `MessageCapacity` bytes in the queue, so traffic passing through (which arrives
///      no faster than it leaves when the ring's links are paced alike) is not squeezed out by local
///      traffic.
///   5. Read errors are reported (`dropped` with the reader's error kind) and counted; the reader resyncs
///      on the next header.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/session/partial_frame_deadline.hpp"
#include "tether/core/session/write_pacer.hpp"
#include "tether/core/status.hpp"
#include "tether/core/time.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/errors.hpp"
#include "tether/elcano/message.hpp"

namespace tether {
namespace elcano {

/// A set of message types (what a node captures).
class TypeSet {
 public:
  /// The empty set.
  constexpr TypeSet() : bits_(0) {}
  /// The set of one type.
  static TypeSet of(Type type) { return TypeSet().with(type); }
  /// This set plus `type`.
  TypeSet with(Type type) const { return TypeSet(static_cast<uint8_t>(bits_ | bit(type))); }
  /// This set without `type`.
  TypeSet without(Type type) const { return TypeSet(static_cast<uint8_t>(bits_ & ~bit(type))); }
  /// True when `type` is in the set.
  bool contains(Type type) const { return (bits_ & bit(type)) != 0; }
  /// The set as four bits (drive 1, sensor 2, goal 4, segment 8): how EEPROM and configs store it.
  uint8_t bits() const { return bits_; }
  /// The set stored as `bits()`; unknown bits are ignored.
  static TypeSet from_bits(uint8_t bits) { return TypeSet(static_cast<uint8_t>(bits & 0x0Fu)); }
  /// Equality.
  bool operator==(const TypeSet& other) const { return bits_ == other.bits_; }
  /// Inequality.
  bool operator!=(const TypeSet& other) const { return bits_ != other.bits_; }

 private:
  explicit constexpr TypeSet(uint8_t bits) : bits_(bits) {}
  static uint8_t bit(Type type) {
    switch (type) {
      case Type::drive: return 1u;
      case Type::sensor: return 2u;
      case Type::goal: return 4u;
      case Type::segment: return 8u;
    }
    return 0u;
  }
  uint8_t bits_;
};

/// How a node behaves on its link.
struct RingNodeConfig {
  Generation generation = Generation::b;  ///< Wire generation of the whole ring.
  TypeSet capture;                        ///< Types this node consumes.
  /// A message must complete within this time after its header (rule 3). At 9600 baud a 96-byte message
  /// takes 100 ms; paced links stretch it further, hence the margin.
  Duration partial_message_timeout = 250;
  /// How long an originated message is remembered to recognise it coming back (rule 2). Must exceed the
  /// ring's round trip (a three-board ring at 115200 baud: a few ms).
  Duration return_timeout = 2000;
  session::LinkPacing pacing;  ///< The link to the next node (rule 4).
};

/// Counters of a node's ring behaviour (the reader's errors go to `LinkCounters`).
struct RingCounters {
  uint32_t captured = 0;           ///< Messages consumed by this node.
  uint32_t forwarded = 0;          ///< Messages queued for the next node.
  uint32_t originated = 0;         ///< Messages this node sent.
  uint32_t undeliverable = 0;      ///< Own messages that came back (nobody captured them).
  uint32_t queue_full_drops = 0;   ///< Messages to forward dropped because the output queue was full.
  uint32_t origins_expired = 0;    ///< Origin records that expired without the message coming back.
  /// Origin records overwritten before expiry because every slot was taken (the oldest goes): if that
  /// message was still travelling and nobody captures it, it is no longer recognised. Non-zero means
  /// the node originates faster than `OriginSlots` per round trip: give it more slots.
  uint32_t origins_evicted = 0;
};

/// What one byte (or one poll) produced.
struct RingEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,           ///< Nothing to report.
    captured,       ///< `message` is of a captured type: it is the application's.
    forwarded,      ///< `message` was queued for the next node.
    undeliverable,  ///< `message`, originated here, came back: nobody captured it (reported once).
    dropped,        ///< Bytes were dropped; `error` says why (a read error, `timed_out`, `queue_full`).
  };
  Kind kind = Kind::none;               ///< What happened.
  Error error = Error::success; ///< For `dropped`.
  Message message;                      ///< For `captured`, `forwarded`, `undeliverable`, `queue_full`.
};

/// Short name of an event kind.
const char* to_string(RingEvent::Kind kind);

/// A ring node holding messages of up to `MessageCapacity` bytes, an output queue of `OutputCapacity`
/// bytes (a power of two, at most 256; it holds one byte less) and `OriginSlots` origin records.
template <size_t MessageCapacity = 96, size_t OutputCapacity = 256, uint8_t OriginSlots = 4>
class RingNode {
  static_assert(OutputCapacity >= 2 && OutputCapacity <= 256 && (OutputCapacity & (OutputCapacity - 1)) == 0,
                "the output queue is a power of two of at most 256 bytes");
  static_assert(OriginSlots >= 1, "a node needs at least one origin record");
  static_assert(OutputCapacity - 1 >= 2 * MessageCapacity,
                "the output queue holds an originated message plus the reserve for forwarding");

 public:
  /// Node with `config` at `now`; `link` and `ring` counters outlive it.
  RingNode(const RingNodeConfig& config, Millis now, LinkCounters& link, RingCounters& ring)
      : config_(config),
        reader_(config.generation, link),
        partial_(config.partial_message_timeout, link),
        pacer_(config.pacing, now),
        counters_(&ring) {}

  /// Consumes one byte from the previous node; the whole event by value (copies the message).
  RingEvent feed(uint8_t byte, Millis now);
  /// Consumes one byte; the fast path without a copy per byte (the firmware's): on `captured`,
  /// `forwarded`, `undeliverable` and a `queue_full` drop read `message()`, on `dropped` read `error()`,
  /// before the next byte.
  RingEvent::Kind consume(uint8_t byte, Millis now);
  /// Consumes `bytes` up to and including the first one that produces an event; `consumed` says how
  /// many were used (feed the rest after handling the event). The same events as `consume(byte, now)`
  /// byte by byte, through the reader's span loop (a call per byte dominates the AVR's cost).
  RingEvent::Kind consume(ByteView bytes, Millis now, size_t& consumed);
  /// The whole event `consume` just reported as `kind`, as `feed` returns it (message and error copied).
  RingEvent event(RingEvent::Kind kind) const;
  /// The message of the last event that had one (valid until the next byte).
  const Message& message() const { return reader_.frame(); }
  /// With `message()`: the `field_bits` of its fields that may hold a value (`Decoder::fields()`).
  uint8_t message_fields() const { return reader_.fields(); }
  /// Why the last `dropped` event dropped.
  Error error() const { return error_; }
  /// Queues `message` for the next node and remembers it (rule 2). `Status::invalid_argument` when it
  /// lacks a field its type requires, `Status::busy` when the output queue has no room for it beside the
  /// forwarding reserve (rule 4): try again after `take_output`.
  Status originate(const Message& message, Millis now);
  /// Moves paced output bytes into `out`; returns how many. Write them to the next node now.
  size_t take_output(MutableByteView out, Millis now);
  /// Handles expired deadlines, one at a time (partial message, origin records). Call until `none`.
  RingEvent poll(Millis now);
  /// When `poll` or `take_output` next has something to do (disarmed when nothing is pending). Without
  /// `include_output` only `poll`'s deadlines count: a caller whose write is still in progress takes the
  /// output when the write completes, and a pacer deadline already due would wake it in a loop.
  Deadline next_wakeup(Millis now, bool include_output = true);

  /// Replaces the capture set (e.g. a host awaiting a reply type).
  void set_capture(TypeSet capture) { config_.capture = capture; }
  /// The node's configuration.
  const RingNodeConfig& config() const { return config_; }
  /// Bytes waiting in the output queue.
  size_t pending_output() const { return static_cast<size_t>(static_cast<uint8_t>(head_ - tail_)); }
  /// Room left in the output queue.
  size_t output_room() const { return OutputCapacity - 1 - pending_output(); }
  /// True while a message is being received.
  bool in_message() const { return reader_.in_frame(); }
  /// Forgets the partial message, the output queue and the origin records (e.g. after a link failure).
  void reset();

 private:
  struct Origin {
    bool used = false;
    uint8_t length = 0;
    uint16_t crc = 0;
    Deadline expires;
  };

  static uint16_t signature_crc(ByteView stripped) { return Crc16Mcrf4xx::compute(stripped); }
  bool enqueue(ByteView bytes);
  bool came_back(ByteView stripped);
  // What the reader's status after a byte (or a span) means for the node.
  RingEvent::Kind on_read(DecodeStatus read, Millis now);

  RingNodeConfig config_;
  Decoder<MessageCapacity> reader_;
  session::PartialFrameDeadline partial_;
  session::WritePacer pacer_;
  RingCounters* counters_;
  Error error_ = Error::success;
  uint8_t queue_[OutputCapacity];
  uint8_t head_ = 0;  // next write (mod OutputCapacity)
  uint8_t tail_ = 0;  // next read
  // Records in use: the loops over origins_ (every completed message, every poll) run only when one is,
  // and a node that originates nothing never looks at them.
  uint8_t origins_used_ = 0;
  Origin origins_[OriginSlots];
};

}  // namespace elcano
}  // namespace tether

#include "tether/elcano/ring_node_impl.hpp"
