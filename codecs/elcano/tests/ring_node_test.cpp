// RingNode: one test per rule of ring_node.hpp, on a fake clock, plus rings of several nodes wired in
// memory (each node's output fed to the next one).
#include "tether/elcano/ring_node.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <cstdio>
#include <string>
#include <vector>

#include "tether/testing/random_seed.hpp"

namespace tether::elcano {
namespace {

using Node = RingNode<96, 256, 4>;

RingNodeConfig config(TypeSet capture, Generation generation = Generation::b) {
  RingNodeConfig c;
  c.generation = generation;
  c.capture = capture;
  c.pacing.receiver_poll_interval = 0;
  return c;
}

struct Fed {
  std::vector<RingEvent> events;  // everything but `none`
};

template <typename AnyNode>
Fed feed(AnyNode& node, const std::string& bytes, Millis now) {
  Fed fed;
  for (char c : bytes) {
    const RingEvent event = node.feed(static_cast<uint8_t>(c), now);
    if (event.kind != RingEvent::Kind::none) fed.events.push_back(event);
  }
  return fed;
}

template <typename AnyNode>
std::string output(AnyNode& node, Millis now) {
  uint8_t buffer[512];
  const size_t size = node.take_output(MutableByteView(buffer, sizeof buffer), now);
  return std::string(reinterpret_cast<char*>(buffer), size);
}

// Rule 1: captured types are consumed; others are forwarded as the reader's forward bytes.
TEST(RingNode, CapturesItsTypesAndForwardsTheRestWhitespaceStripped) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet::of(Type::goal)), 0, link, ring);
  Fed fed = feed(node, "G{n 2}{b 679}{p 0,0}{r 59}\nD{s 5 0}{a 25}\n", 0);
  ASSERT_EQ(fed.events.size(), 2u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::captured);
  EXPECT_EQ(fed.events[0].message.probability, 59);
  EXPECT_EQ(fed.events[1].kind, RingEvent::Kind::forwarded);
  EXPECT_EQ(output(node, 0), "D{s50}{a25}\n");
  EXPECT_EQ(ring.captured, 1u);
  EXPECT_EQ(ring.forwarded, 1u);
}

TEST(RingNode, GenerationDForwardsByteIdentical) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet::of(Type::drive), Generation::d), 0, link, ring);
  const std::string segment = "X{n4}{s160}{b80}{p3200}{q-64000}243\n";
  Fed fed = feed(node, segment + "D{s50}{a25}74\n", 0);
  ASSERT_EQ(fed.events.size(), 2u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::forwarded);
  EXPECT_EQ(fed.events[1].kind, RingEvent::Kind::captured);
  std::string out;
  for (Millis now = 0; now < 10; ++now) out += output(node, now);
  EXPECT_EQ(out, segment);
}

TEST(RingNode, MessagesLeaveWholeAndInOrderWithOriginatedOnes) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet()), 0, link, ring);
  feed(node, "D{s 1}{a 1}\n", 0);
  ASSERT_EQ(node.originate(Message::drive(2, 2), 0), Status::ok);
  feed(node, "D{s 3}{a 3}\n", 0);
  EXPECT_EQ(output(node, 0), "D{s1}{a1}\nD{s 2}{a 2}\nD{s3}{a3}\n");
}

// Rule 2: an own message coming back is undeliverable, reported once; the wire format is untouched.
TEST(RingNode, OwnMessageComingBackIsReportedUndeliverableOnce) {
  LinkCounters link;
  RingCounters ring;
  Node origin(config(TypeSet()), 0, link, ring);
  ASSERT_EQ(origin.originate(Message::drive(50, 25), 0), Status::ok);
  const std::string sent = output(origin, 0);
  EXPECT_EQ(sent, "D{s 50}{a 25}\n");  // the spec's writer format: nothing added for loop protection
  // Round the ring: another node forwards it (whitespace-stripped), then it reaches the origin again.
  LinkCounters other_link;
  RingCounters other_ring;
  Node other(config(TypeSet()), 0, other_link, other_ring);
  feed(other, sent, 1);
  const std::string back = output(other, 1);
  EXPECT_EQ(back, "D{s50}{a25}\n");
  Fed fed = feed(origin, back, 2);
  ASSERT_EQ(fed.events.size(), 1u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::undeliverable);
  EXPECT_EQ(fed.events[0].message.speed, 50);
  EXPECT_EQ(output(origin, 2), "");  // dropped, not sent round again
  EXPECT_EQ(ring.undeliverable, 1u);
  // The same bytes arriving again are somebody else's message now: forwarded.
  fed = feed(origin, back, 3);
  ASSERT_EQ(fed.events.size(), 1u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::forwarded);
}

TEST(RingNode, TheSameMessageSentTwiceComesBackTwice) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet()), 0, link, ring);
  ASSERT_EQ(node.originate(Message::drive(1, 1), 0), Status::ok);
  ASSERT_EQ(node.originate(Message::drive(1, 1), 0), Status::ok);
  output(node, 0);
  Fed fed = feed(node, "D{s1}{a1}\nD{s1}{a1}\nD{s1}{a1}\n", 5);
  ASSERT_EQ(fed.events.size(), 3u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::undeliverable);
  EXPECT_EQ(fed.events[1].kind, RingEvent::Kind::undeliverable);
  EXPECT_EQ(fed.events[2].kind, RingEvent::Kind::forwarded);
}

TEST(RingNode, OriginRecordsExpireAfterTheReturnTimeout) {
  LinkCounters link;
  RingCounters ring;
  RingNodeConfig c = config(TypeSet());
  c.return_timeout = 100;
  Node node(c, 0, link, ring);
  ASSERT_EQ(node.originate(Message::drive(1, 1), 0), Status::ok);
  output(node, 0);
  EXPECT_TRUE(node.next_wakeup(0).armed());
  EXPECT_EQ(node.next_wakeup(0).at(), 100u);
  EXPECT_EQ(node.poll(99).kind, RingEvent::Kind::none);
  EXPECT_EQ(ring.origins_expired, 0u);
  node.poll(100);
  EXPECT_EQ(ring.origins_expired, 1u);  // consumed somewhere (or lost): no longer ours to recognise
  Fed fed = feed(node, "D{s1}{a1}\n", 101);
  EXPECT_EQ(fed.events.at(0).kind, RingEvent::Kind::forwarded);
  EXPECT_FALSE(node.next_wakeup(101).armed() && node.pending_output() == 0);
}

TEST(RingNode, ARingOfThreeReturnsAnUncapturedMessageToItsOriginOnly) {
  // host -> a -> b -> host; a captures goals, nobody captures drives.
  LinkCounters link[3];
  RingCounters ring[3];
  Node host(config(TypeSet::of(Type::sensor)), 0, link[0], ring[0]);
  Node a(config(TypeSet::of(Type::goal)), 0, link[1], ring[1]);
  Node b(config(TypeSet()), 0, link[2], ring[2]);
  ASSERT_EQ(host.originate(Message::goal(1, 90, 100, -200), 0), Status::ok);
  ASSERT_EQ(host.originate(Message::drive(7, 8), 0), Status::ok);
  std::vector<RingEvent> host_events;
  for (Millis now = 0; now < 10; ++now) {
    feed(a, output(host, now), now);
    feed(b, output(a, now), now);
    for (const RingEvent& e : feed(host, output(b, now), now).events) host_events.push_back(e);
  }
  EXPECT_EQ(ring[1].captured, 1u);
  EXPECT_EQ(ring[1].forwarded, 1u);
  EXPECT_EQ(ring[2].forwarded, 1u);
  ASSERT_EQ(host_events.size(), 1u);
  EXPECT_EQ(host_events[0].kind, RingEvent::Kind::undeliverable);
  EXPECT_EQ(host_events[0].message.type, Type::drive);
  EXPECT_EQ(ring[0].undeliverable, 1u);
  EXPECT_EQ(host.pending_output() + a.pending_output() + b.pending_output(), 0u);  // it stopped circulating
}

// Rule 3: partial messages are dropped at their deadline, and the next message is read normally.
TEST(RingNode, PartialMessageIsDroppedAtItsDeadline) {
  LinkCounters link;
  RingCounters ring;
  RingNodeConfig c = config(TypeSet::of(Type::drive));
  c.partial_message_timeout = 250;
  Node node(c, 0, link, ring);
  feed(node, "D{s 5", 1000);
  EXPECT_TRUE(node.in_message());
  ASSERT_TRUE(node.next_wakeup(1000).armed());
  EXPECT_EQ(node.next_wakeup(1000).at(), 1250u);
  EXPECT_EQ(node.poll(1249).kind, RingEvent::Kind::none);
  const RingEvent dropped = node.poll(1250);
  EXPECT_EQ(dropped.kind, RingEvent::Kind::dropped);
  EXPECT_EQ(dropped.error, Error::timed_out);
  EXPECT_EQ(link.partial_timeouts, 1u);
  EXPECT_FALSE(node.in_message());
  // The rest of the stale message is skipped; the next message is whole.
  Fed fed = feed(node, "0}{a 1}\nD{s 9}{a 9}\n", 1300);
  ASSERT_EQ(fed.events.size(), 1u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::captured);
  EXPECT_EQ(fed.events[0].message.speed, 9);
}

TEST(RingNode, CompleteMessagesNeverTimeOut) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet::of(Type::drive)), 0, link, ring);
  feed(node, "D{s 1}{a 2}\n", 0);
  EXPECT_FALSE(node.next_wakeup(0).armed());
  EXPECT_EQ(node.poll(100000).kind, RingEvent::Kind::none);
  EXPECT_EQ(link.partial_timeouts, 0u);
}

// Rule 4: output is paced; a full queue drops (and reports) forwarded messages and refuses originated ones.
TEST(RingNode, OutputIsPacedForASlowReceiver) {
  LinkCounters link;
  RingCounters ring;
  RingNodeConfig c = config(TypeSet());
  c.pacing.receiver_buffer = 64;
  c.pacing.receiver_poll_interval = 20;  // 32-byte bursts, 1.6 bytes per ms
  Node node(c, 0, link, ring);
  for (int i = 0; i < 6; ++i) ASSERT_EQ(node.originate(Message::drive(1000 + i, 10), 0), Status::ok);
  EXPECT_EQ(output(node, 0).size(), 32u);
  EXPECT_EQ(output(node, 0).size(), 0u);
  const Deadline wake = node.next_wakeup(0);
  ASSERT_TRUE(wake.armed());
  EXPECT_EQ(wake.at(), 20u);  // 32 more bytes after 20 ms
  EXPECT_EQ(output(node, 20).size(), 32u);
  // Without the output (a write still in progress), only poll's deadlines count: the origin records',
  ASSERT_TRUE(node.next_wakeup(20, false).armed());
  EXPECT_EQ(node.next_wakeup(20, false).at(), node.config().return_timeout);
  feed(node, "D{s 1", 21);  // and a partial message's, earlier
  ASSERT_TRUE(node.next_wakeup(21, false).armed());
  EXPECT_EQ(node.next_wakeup(21, false).at(), 21u + node.config().partial_message_timeout);
}

TEST(RingNode, FullQueueDropsForwardsWithAReportAndPushesBackOnOriginate) {
  LinkCounters link;
  RingCounters ring;
  // 16-byte messages, a queue of 63 bytes: originate keeps 16 bytes free for forwarding.
  RingNode<16, 64, 2> node(config(TypeSet()), 0, link, ring);
  ASSERT_EQ(node.originate(Message::drive(10, 10), 0), Status::ok);  // "D{s 10}{a 10}\n": 14 bytes
  ASSERT_EQ(node.originate(Message::drive(20, 20), 0), Status::ok);  // 28
  ASSERT_EQ(node.originate(Message::drive(30, 30), 0), Status::ok);  // 42
  EXPECT_EQ(node.originate(Message::drive(40, 40), 0), Status::busy);  // 56 would leave 7 < 16
  std::vector<RingEvent> events = feed(node, "D{s1}{a1}\nD{s2}{a2}\nD{s3}{a3}\n", 0).events;  // 10 bytes each
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].kind, RingEvent::Kind::forwarded);  // the reserve takes them: 52,
  EXPECT_EQ(events[1].kind, RingEvent::Kind::forwarded);  // 62 of 63 bytes
  EXPECT_EQ(events[2].kind, RingEvent::Kind::dropped);    // 72 would not fit: reported
  EXPECT_EQ(events[2].error, Error::queue_full);
  EXPECT_EQ(ring.queue_full_drops, 1u);
}

TEST(RingNode, EvictedOriginRecordsAreCounted) {
  LinkCounters link;
  RingCounters ring;
  RingNode<96, 256, 2> node(config(TypeSet()), 0, link, ring);
  for (int i = 0; i < 3; ++i) ASSERT_EQ(node.originate(Message::drive(i, i), static_cast<Millis>(i)), Status::ok);
  EXPECT_EQ(ring.origins_evicted, 1u);
  output(node, 10);
  // The first one's record was overwritten: it is forwarded again; the two others are recognised.
  std::vector<RingEvent::Kind> kinds;
  for (char ch : std::string("D{s0}{a0}\nD{s1}{a1}\nD{s2}{a2}\n")) {
    const RingEvent e = node.feed(static_cast<uint8_t>(ch), 11);
    if (e.kind != RingEvent::Kind::none) kinds.push_back(e.kind);
  }
  EXPECT_EQ(kinds, (std::vector<RingEvent::Kind>{RingEvent::Kind::forwarded, RingEvent::Kind::undeliverable,
                                                 RingEvent::Kind::undeliverable}));
}

TEST(RingNode, OriginateRejectsAMessageMissingRequiredFields) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet()), 0, link, ring);
  Message incomplete;
  incomplete.type = Type::drive;
  incomplete.speed = 5;
  EXPECT_EQ(node.originate(incomplete, 0), Status::invalid_argument);
  EXPECT_EQ(node.pending_output(), 0u);
  EXPECT_EQ(ring.originated, 0u);
}

// Rule 5: read errors are reported and counted; the node resyncs on the next header.
TEST(RingNode, ReadErrorsAreReportedAndTheNextMessageGetsThrough) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet::of(Type::drive), Generation::d), 0, link, ring);
  Fed fed = feed(node, "D{s50}{a25}75\nD{s1500}{a60}179\n", 0);
  ASSERT_EQ(fed.events.size(), 2u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::dropped);
  EXPECT_EQ(fed.events[0].error, Error::bad_crc);
  EXPECT_EQ(fed.events[1].kind, RingEvent::Kind::captured);
  EXPECT_EQ(link.crc_errors, 1u);
}

// docs/elcano.md, "Compatibility with the reference reader": the reference forwards a message of a type it
// does not capture without reading it, malformed or not; a Tether node reads everything it forwards and
// drops (and reports) what it cannot read, so a damaged message never goes round the ring.
TEST(RingNode, AMalformedMessageOfAnUncapturedTypeIsDroppedNotForwarded) {
  LinkCounters link;
  RingCounters ring;
  Node node(config(TypeSet::of(Type::drive)), 0, link, ring);
  Fed fed = feed(node, "S{s 1}{a 2}{b 3}{p 4}\nS{s 1}{a 2}{b 3}{p 4,5}\n", 0);
  ASSERT_EQ(fed.events.size(), 2u);
  EXPECT_EQ(fed.events[0].kind, RingEvent::Kind::dropped);
  EXPECT_EQ(fed.events[0].error, Error::bad_number);
  EXPECT_EQ(fed.events[1].kind, RingEvent::Kind::forwarded);
  EXPECT_EQ(output(node, 0), "S{s1}{a2}{b3}{p4,5}\n");  // only the well-formed one
  EXPECT_EQ(ring.forwarded, 1u);
  EXPECT_EQ(link.framing_errors, 1u);
}

// A ring under random traffic: everything originated is captured or comes back undeliverable exactly once.
// What a node did, as text: every event with its message or error, then the output and the counters.
std::string describe(const RingEvent::Kind kind, const Node& node) {
  if (kind == RingEvent::Kind::none) return "";
  std::string text = std::string(to_string(kind));
  if (kind == RingEvent::Kind::dropped) text += " error " + std::to_string(static_cast<int>(node.error()));
  if (kind != RingEvent::Kind::dropped || node.error() == Error::queue_full) {
    const Message& m = node.message();
    text += " " + std::string(1, static_cast<char>(m.type));
    for (const int32_t field : {m.number, m.speed, m.angle, m.obstacle, m.bearing, m.probability, m.east, m.north}) {
      text += " " + std::to_string(field);
    }
  }
  return text + "\n";
}

TEST(RingNode, SpanConsumeDoesExactlyWhatByteConsumeDoes) {
  // consume(bytes) (the firmware's: the reader's span loop, the deadline followed once per span) against
  // consume(byte) byte by byte: the same events, output, deadlines and counters, chunk after chunk.
  std::mt19937_64 random = testing::seeded_generator(171);
  const std::vector<std::string> pieces = {"D{s 50}{a 25}\n", "X{n 4}{s 160}{b 80}{p 3200,-64000}\n", "D{s50}{a25}74\n",
                                           "G{n 1}{b 2}{p 3,4}\n", "D{s 5", "}{a 1}\n", "Q{s 1}\n", "D{s 1x}\n",
                                           "  ", "\n", "D{s 1}D{s 2}{a 3}\n", "S{s1}{a2}{b3}{p4}{q5}27\n"};
  std::uniform_int_distribution<size_t> pick(0, pieces.size() - 1);
  std::uniform_int_distribution<size_t> chunk_size(1, 24);
  std::uniform_int_distribution<int> step(0, 200);
  for (int round = 0; round < 200; ++round) {
    const Generation generation = round % 2 == 0 ? Generation::b : Generation::d;
    const TypeSet capture = TypeSet::from_bits(static_cast<uint8_t>(round / 2 % 16));
    LinkCounters link_a, link_b;
    RingCounters ring_a, ring_b;
    Node by_byte(config(capture, generation), 0, link_a, ring_a);
    Node by_span(config(capture, generation), 0, link_b, ring_b);
    // Some of the node's own messages, so that some come back.
    ASSERT_EQ(by_byte.originate(Message::drive(7, 8), 0), by_span.originate(Message::drive(7, 8), 0));
    std::string stream;
    for (int i = 0; i < 12; ++i) stream += pieces[pick(random)];
    stream += generation == Generation::b ? "D{s 7}{a 8}\n" : "D{s7}{a8}247\n";
    Millis now = 0;
    std::string a, b;
    for (size_t at = 0; at < stream.size();) {
      now += static_cast<Millis>(step(random));
      const size_t chunk = std::min(chunk_size(random), stream.size() - at);
      for (size_t i = 0; i < chunk; ++i) a += describe(by_byte.consume(static_cast<uint8_t>(stream[at + i]), now), by_byte);
      ByteView rest = ByteView::from_chars(stream.data() + at, chunk);
      while (!rest.empty()) {
        size_t used = 0;
        b += describe(by_span.consume(rest, now, used), by_span);
        ASSERT_GE(used, 1u);
        rest = rest.subview(used);
      }
      at += chunk;
      for (RingEvent e = by_byte.poll(now); e.kind != RingEvent::Kind::none; e = by_byte.poll(now)) a += to_string(e.kind);
      for (RingEvent e = by_span.poll(now); e.kind != RingEvent::Kind::none; e = by_span.poll(now)) b += to_string(e.kind);
      a += output(by_byte, now) + (by_byte.in_message() ? " open" : " closed");
      b += output(by_span, now) + (by_span.in_message() ? " open" : " closed");
      const Deadline wake_a = by_byte.next_wakeup(now), wake_b = by_span.next_wakeup(now);
      a += wake_a.armed() ? " wake " + std::to_string(wake_a.at()) + "\n" : " idle\n";
      b += wake_b.armed() ? " wake " + std::to_string(wake_b.at()) + "\n" : " idle\n";
      ASSERT_EQ(a, b) << "round " << round << ", stream " << stream;
    }
    EXPECT_EQ(ring_a.captured, ring_b.captured);
    EXPECT_EQ(ring_a.forwarded, ring_b.forwarded);
    EXPECT_EQ(ring_a.undeliverable, ring_b.undeliverable);
    EXPECT_EQ(link_a.frames_ok, link_b.frames_ok);
    EXPECT_EQ(link_a.framing_errors, link_b.framing_errors);
    EXPECT_EQ(link_a.partial_timeouts, link_b.partial_timeouts);
    EXPECT_EQ(link_a.resyncs, link_b.resyncs);
  }
}

TEST(RingNode, RandomTrafficOnARingIsDeliveredOrReturnedExactlyOnce) {
  const uint64_t seed = testing::random_seed();
  std::mt19937_64 random(seed);
  constexpr int kNodes = 4;
  LinkCounters link[kNodes];
  RingCounters ring[kNodes];
  // Enough origin records for the rate: one message per 16 ms per node, round trips of tens of ms.
  std::vector<RingNode<96, 256, 16>> nodes;
  nodes.reserve(kNodes);
  const Type types[] = {Type::drive, Type::sensor, Type::goal, Type::segment};
  for (int i = 0; i < kNodes; ++i) {
    // Node i captures type i, except that nobody captures segments.
    RingNodeConfig c = config(i < 3 ? TypeSet::of(types[i]) : TypeSet(), Generation::d);
    c.pacing.receiver_poll_interval = 5;
    c.return_timeout = 500;  // round trips here take tens of ms
    nodes.emplace_back(c, 0, link[i], ring[i]);
  }
  uint32_t sent = 0;
  uint32_t refused = 0;
  for (Millis now = 0; now < 3000; ++now) {
    // About half the ring's capacity: one ~40-byte message per 8 ms over four 6.4 byte/ms links.
    if (now < 2000 && random() % 8 == 0) {
      const int from = static_cast<int>(random() % kNodes);
      Message m;
      m.type = types[random() % 4];
      m.number = static_cast<int32_t>(sent);
      m.speed = static_cast<int32_t>(random() % 3000);
      m.angle = 1;
      m.bearing = 2;
      m.east = 3;
      m.north = static_cast<int32_t>(now);
      if (nodes[static_cast<size_t>(from)].originate(m, now) == Status::ok) {
        ++sent;
      } else {
        ++refused;
      }
    }
    for (int i = 0; i < kNodes; ++i) {
      auto& next = nodes[static_cast<size_t>((i + 1) % kNodes)];
      uint8_t buffer[512];
      const size_t size = nodes[static_cast<size_t>(i)].take_output(MutableByteView(buffer, sizeof buffer), now);
      for (size_t k = 0; k < size; ++k) next.feed(buffer[k], now);
    }
    for (auto& node : nodes) {
      while (node.poll(now).kind != RingEvent::Kind::none) {
      }
    }
  }
  uint32_t captured = 0;
  uint32_t undeliverable = 0;
  uint32_t drops = 0;
  for (int i = 0; i < kNodes; ++i) {
    std::printf("node %d: originated %u captured %u forwarded %u undeliverable %u queue_full %u crc %u framing %u "
                "partial %u evicted %u\n", i, ring[i].originated, ring[i].captured, ring[i].forwarded, ring[i].undeliverable,
                ring[i].queue_full_drops, link[i].crc_errors, link[i].framing_errors, link[i].partial_timeouts, ring[i].origins_evicted);
    captured += ring[i].captured;
    undeliverable += ring[i].undeliverable;
    drops += ring[i].queue_full_drops + link[i].crc_errors + link[i].framing_errors + link[i].partial_timeouts;
  }
  EXPECT_GT(sent, 150u) << "seed " << seed;
  EXPECT_EQ(drops, 0u) << "seed " << seed;
  EXPECT_EQ(captured + undeliverable, sent) << "seed " << seed << ", refused " << refused;
}

}  // namespace
}  // namespace tether::elcano
