// Fuzz target of the Elcano ring node. The input drives one node: byte 0 picks the generation and capture
// set, then each input byte is either a byte from the previous node or, after an escape (0xFF), a command
// (advance the clock, originate a message, drain the output). Invariants: no crash; the output queue never
// exceeds its bound; every event is consistent with the counters; everything the node writes is a sequence
// of whole messages that a reader of the same generation accepts with no error, and there are exactly as
// many as were forwarded plus originated; a partial message never outlives its deadline by a poll.
#include <cstddef>
#include <cstdint>

#include "tether/elcano/decoder.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/testing/fuzz_target.hpp"

using namespace tether;
using namespace tether::elcano;

namespace {

Message sample(uint8_t selector, Millis now) {
  Message m;
  m.type = (selector & 3u) == 0 ? Type::drive : (selector & 3u) == 1 ? Type::sensor
           : (selector & 3u) == 2 ? Type::goal : Type::segment;
  m.number = selector;
  m.speed = static_cast<int32_t>(now % 4000u) - 2000;
  m.angle = -static_cast<int32_t>(selector);
  m.bearing = 7;
  m.east = static_cast<int32_t>(now);
  m.north = -2147483647;
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  RingNodeConfig config;
  config.generation = (data[0] & 0x10u) != 0 ? Generation::d : Generation::b;
  config.capture = TypeSet::from_bits(data[0]);
  config.partial_message_timeout = 50;
  config.return_timeout = 200;
  config.pacing.receiver_buffer = 64;
  config.pacing.receiver_poll_interval = static_cast<uint16_t>((data[0] >> 5) * 5u);
  LinkCounters link;
  RingCounters ring;
  Millis now = 0xFFFFFF00u;  // cross the clock wrap on long inputs
  RingNode<96, 256, 4> node(config, now, link, ring);
  LinkCounters out_link;
  Decoder<96> downstream(config.generation, out_link);
  uint32_t messages_out = 0;
  const auto drain = [&] {
    uint8_t out[300];
    const size_t n = node.take_output(MutableByteView(out, sizeof out), now);
    for (size_t i = 0; i < n; ++i) {
      const DecodeStatus e = downstream.feed(out[i]);
      TETHER_FUZZ_CHECK(e != DecodeStatus::error);
      if (e == DecodeStatus::frame) ++messages_out;
    }
  };
  for (size_t i = 1; i < size; ++i) {
    if (data[i] == 0xFF && i + 1 < size) {
      const uint8_t command = data[++i];
      if (command < 0x80) {
        now += command;
      } else if (command < 0xC0) {
        const Status status = node.originate(sample(command, now), now);
        TETHER_FUZZ_CHECK(status == Status::ok || status == Status::busy);
      } else {
        drain();
      }
    } else {
      const uint32_t before = ring.captured + ring.forwarded + ring.undeliverable + ring.queue_full_drops;
      const RingEvent event = node.feed(data[i], now);
      const uint32_t after = ring.captured + ring.forwarded + ring.undeliverable + ring.queue_full_drops;
      const bool counted = event.kind == RingEvent::Kind::captured || event.kind == RingEvent::Kind::forwarded ||
                           event.kind == RingEvent::Kind::undeliverable ||
                           (event.kind == RingEvent::Kind::dropped && event.error == Error::queue_full);
      TETHER_FUZZ_CHECK(after - before == (counted ? 1u : 0u));
    }
    TETHER_FUZZ_CHECK(node.pending_output() <= 255u);
    while (true) {
      const RingEvent polled = node.poll(now);
      if (polled.kind == RingEvent::Kind::none) break;
      TETHER_FUZZ_CHECK(polled.kind == RingEvent::Kind::dropped && polled.error == Error::timed_out);
    }
    const Deadline wake = node.next_wakeup(now);
    if (node.in_message()) TETHER_FUZZ_CHECK(wake.armed());
  }
  // Let the pacer release everything that is queued: whole messages, as many as went in.
  for (int round = 0; round < 100 && node.pending_output() != 0; ++round) {
    now += 10;
    drain();
  }
  TETHER_FUZZ_CHECK(node.pending_output() == 0);
  TETHER_FUZZ_CHECK(!downstream.in_frame());
  TETHER_FUZZ_CHECK(messages_out == ring.forwarded + ring.originated);
  return 0;
}
