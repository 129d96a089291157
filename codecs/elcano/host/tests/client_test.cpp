// RingClient against a scripted rest-of-the-ring over an in-memory pair: requests answered, re-sent and
// timed out, undeliverable requests failing fast, receives and their bound, forwarding byte for byte,
// pacing of the host's link, waiting for room and the busy cases, close and link failure, generation D.
//
// Time: tests about deadlines (re-sends, timeouts, the send and receive timeouts, pacing) run the client
// on a `ManualClock` and assert on simulated time: the deadline the client armed is exactly the one the
// spec names, and nothing happens before the clock reaches it. Every other test runs on `Link`'s manual
// clock too (no deadline passes), except those whose pacing must see time pass (`on_steady_clock`, with
// windows far beyond `kPrompt`). None bounds elapsed time: `kPrompt` only says "it happened at all"; where a test must show that
// something did NOT wait for a deadline, the deadline is far longer than `kPrompt` and the outcome tells.
#include <gtest/gtest.h>

#include <boost/asio/error.hpp>
#include <boost/asio/use_future.hpp>
#include <boost/system/system_error.hpp>

#include <atomic>
#include <future>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "fake_ring.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::elcano::testing {
namespace {

namespace asio = boost::asio;
using IoThread = transports::IoThread;
using namespace std::chrono_literals;

bool same(const Message& a, const Message& b) { return wire(a, Generation::d) == wire(b, Generation::d); }

// A script answering every goal with segment `number`.
FakeRing::Script answer_goals_with_segment(std::int32_t number, Generation generation = Generation::b) {
  return [number, generation](const RingRecord& record, FakeRing& ring) {
    if (record.ok && record.message.type == Type::goal) ring.send(wire(segment(number), generation));
  };
}

// A ring where no board captures goals: every goal comes back to the host as it left it. (Only goals: the
// host forwards what it does not recognise, so echoing everything would circulate a foreign message forever.)
FakeRing::Script echo_goals() {
  return [](const RingRecord& record, FakeRing& ring) {
    if (record.ok && record.message.type == Type::goal) ring.send(record.wire);
  };
}

std::size_t count_of(const std::vector<RingRecord>& records, Type type) {
  std::size_t count = 0;
  for (const auto& record : records) count += record.ok && record.message.type == type ? 1 : 0;
  return count;
}

// --- requests ------------------------------------------------------------------------------------------

TEST(RingClient, RequestIsAnsweredByTheFirstMessageOfTheReplyType) {
  IoThread io;
  Link link(io.executor(), test_options(), answer_goals_with_segment(7));
  const Message reply = link.client->request(goal(1), Type::segment);
  EXPECT_TRUE(same(reply, segment(7)));
  const auto records = link.ring->messages();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].wire, "G{n 1}{b 90}{p 100,200}\n");  // generation B, as the writer writes it
  const Counters counters = link.client->counters();
  EXPECT_EQ(counters.replies, 1u);
  EXPECT_EQ(counters.ring.originated, 1u);
  EXPECT_EQ(counters.ring.captured, 1u);
  EXPECT_EQ(counters.ring.forwarded, 0u);
  EXPECT_EQ(counters.link.retries, 0u);
  EXPECT_EQ(counters.bytes_written, records[0].wire.size());
}

TEST(RingClient, RequestWorksWithEveryCompletionForm) {
  IoThread io;
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)), answer_goals_with_segment(3));
  std::future<Message> future = link.client->async_request(goal(1), Type::segment, asio::use_future);
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_TRUE(same(future.get(), segment(3)));

  Completions completions;
  link.client->async_request(goal(2), Type::segment, completions.message_handler(0));
  ASSERT_TRUE(completions.wait_for(1));
  EXPECT_FALSE(completions.at(0)->error);
  EXPECT_TRUE(same(*completions.at(0)->message, segment(3)));

  error_code error;
  const Message reply = link.client->request(goal(3), Type::segment, error);
  EXPECT_FALSE(error);
  EXPECT_TRUE(same(reply, segment(3)));
  EXPECT_EQ(link.client->counters().replies, 3u);
}

TEST(RingClient, LostReplyIsRecoveredByAResendOfTheSameBytes) {
  IoThread io;
  // The first goal's answer is lost somewhere in the ring; the second is answered.
  auto clock = ManualClock::create();
  Link link(io.executor(), test_options(200, 2000, clock), [](const RingRecord& record, FakeRing& ring) {
    if (!record.ok || record.message.type != Type::goal) return;
    if (ring.messages().size() >= 2) ring.send(wire(segment(9)));
  });
  const Millis sent = clock->now();
  std::future<Message> reply = link.client->async_request(goal(1), Type::segment, asio::use_future);
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  Millis due = 0;
  ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(sent + 200), due)) << "next deadline: +" << due - sent;
  clock->advance(199);
  EXPECT_EQ(clock->pending(), 1u);  // not yet due: no re-send
  clock->advance(1);                // the attempt window: the same bytes again
  ASSERT_EQ(reply.wait_for(kPrompt), std::future_status::ready);
  EXPECT_TRUE(same(reply.get(), segment(9)));
  const auto records = link.ring->messages();
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].wire, records[1].wire);
  const Counters counters = link.client->counters();
  EXPECT_EQ(counters.link.retries, 1u);
  EXPECT_EQ(counters.ring.originated, 2u);
  EXPECT_EQ(counters.replies, 1u);
}

TEST(RingClient, SilentRingTimesOutAfterEveryAttempt) {
  IoThread io;
  auto clock = ManualClock::create();
  Link link(io.executor(), test_options(100, 1000, clock));
  const Millis sent = clock->now();
  Completions completions;
  link.client->async_request(goal(1), Type::segment, completions.message_handler(0));
  for (std::uint32_t attempt = 1; attempt <= 3; ++attempt) {  // each attempt window, exactly
    ASSERT_TRUE(link.ring->wait_for_messages(attempt));
    Millis due = 0;
    ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(sent + 100 * attempt), due)) << "+" << due - sent;
    EXPECT_EQ(completions.calls(), 0u);
    clock->advance_to(due);
  }
  ASSERT_TRUE(completions.wait_for(1));
  const error_code error = completions.at(0)->error;
  EXPECT_EQ(error, RingError::timed_out);
  EXPECT_EQ(error, boost::system::errc::timed_out);
  EXPECT_TRUE(same(*completions.at(0)->message, Message()));
  ASSERT_TRUE(link.ring->wait_for_messages(3));
  EXPECT_EQ(count_of(link.ring->messages(), Type::goal), 3u);
  const Counters counters = link.client->counters();
  EXPECT_EQ(counters.link.retries, 2u);
  EXPECT_EQ(counters.link.timeouts, 1u);
  // The reply type is no longer captured: a late segment is forwarded.
  link.ring->send(wire(segment(5)));
  ASSERT_TRUE(link.ring->wait_for_messages(4));
  EXPECT_TRUE(same(link.ring->messages()[3].message, segment(5)));
  std::future<Message> again = link.client->async_request(goal(2), Type::segment, asio::use_future);
  ASSERT_TRUE(clock->advance_until([&] { return again.wait_for(0ms) == std::future_status::ready; }));
  EXPECT_THROW(again.get(), boost::system::system_error);
}

TEST(RingClient, UndeliverableRequestFailsFastAndIsReportedOnce) {
  IoThread io;
  // Attempt window and budget far beyond kPrompt: a timeout cannot be what ends the call.
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)), echo_goals());
  std::future<Message> future = link.client->async_request(goal(1), Type::segment, asio::use_future);
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  try {
    future.get();
    ADD_FAILURE() << "the request should have failed";
  } catch (const boost::system::system_error& failure) {
    EXPECT_EQ(failure.code(), RingError::undeliverable);
  }
  ASSERT_TRUE(link.log.wait_for<events::Undeliverable>());
  const auto reports = link.log.of<events::Undeliverable>();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_TRUE(reports[0].request_failed);
  EXPECT_TRUE(same(reports[0].message, goal(1)));
  // The echo was dropped, not forwarded round again: a marker sent after it arrives right after the goal.
  link.ring->send(wire(Message::drive(1, 2)));
  ASSERT_TRUE(link.ring->wait_for_messages(2));
  const auto records = link.ring->messages();
  EXPECT_EQ(records[0].message.type, Type::goal);
  EXPECT_TRUE(same(records[1].message, Message::drive(1, 2)));
  const Counters counters = link.client->counters();
  EXPECT_EQ(counters.ring.undeliverable, 1u);
  EXPECT_EQ(counters.link.retries, 0u);
  EXPECT_EQ(counters.ring.originated, 1u);
}

TEST(RingClient, UndeliverableSendIsReportedOnce) {
  IoThread io;
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)), [](const RingRecord& record, FakeRing& ring) {
    if (record.ok && record.message.type == Type::drive) ring.send(record.wire);  // nobody takes drives
  });
  link.client->send(Message::drive(50, 25));
  ASSERT_TRUE(link.log.wait_for<events::Undeliverable>());
  // One more message through the ring proves the echo was handled (and not forwarded) before it.
  link.ring->send(wire(goal(4)));
  ASSERT_TRUE(link.ring->wait_for_messages(2));
  const auto records = link.ring->messages();
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[1].message.type, Type::goal);
  const auto reports = link.log.of<events::Undeliverable>();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_FALSE(reports[0].request_failed);
  EXPECT_TRUE(same(reports[0].message, Message::drive(50, 25)));
  EXPECT_EQ(link.client->counters().ring.undeliverable, 1u);
}

TEST(RingClient, ReplyTypeIsCapturedOnlyWhileARequestAwaitsIt) {
  IoThread io;
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)));
  // No request: a segment passes through.
  link.ring->send(wire(segment(1)));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  // A request awaiting segments: the next one is its reply, not forwarded.
  Completions completions;
  link.client->async_request(goal(1), Type::segment, completions.message_handler(0));
  ASSERT_TRUE(link.ring->wait_for_messages(2));  // the goal went out
  link.ring->send(wire(segment(2)));
  ASSERT_TRUE(completions.wait_for(1));
  EXPECT_FALSE(completions.at(0)->error);
  EXPECT_TRUE(same(*completions.at(0)->message, segment(2)));
  // Done: segments pass through again.
  link.ring->send(wire(segment(3)));
  ASSERT_TRUE(link.ring->wait_for_messages(3));
  const auto records = link.ring->messages();
  EXPECT_TRUE(same(records[0].message, segment(1)));
  EXPECT_EQ(records[1].message.type, Type::goal);
  EXPECT_TRUE(same(records[2].message, segment(3)));
  EXPECT_EQ(link.client->counters().ring.forwarded, 2u);
}

// --- busy ----------------------------------------------------------------------------------------------

TEST(RingClient, SecondRequestForTheSameReplyTypeIsBusy) {
  IoThread io;
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)));  // nobody answers
  Completions completions;
  link.client->async_request(goal(1), Type::segment, completions.message_handler(0));
  link.client->async_request(goal(2), Type::segment, completions.message_handler(1));
  link.client->async_request(Message::drive(1, 1), Type::sensor, completions.message_handler(2));  // another type: fine
  ASSERT_TRUE(completions.wait_for(1));
  ASSERT_TRUE(completions.at(1).has_value());
  EXPECT_EQ(completions.at(1)->error, RingError::reply_type_busy);
  EXPECT_EQ(completions.at(1)->error, boost::system::errc::device_or_resource_busy);
  ASSERT_TRUE(link.ring->wait_for_messages(2));  // goal 1 and the drive; goal 2 never went out
  const auto records = link.ring->messages();
  EXPECT_TRUE(same(records[0].message, goal(1)));
  EXPECT_TRUE(same(records[1].message, Message::drive(1, 1)));
  EXPECT_EQ(completions.calls(), 1u);
  link.client->close();
  ASSERT_TRUE(completions.wait_for(3));
  EXPECT_EQ(completions.at(0)->error, asio::error::operation_aborted);
  EXPECT_EQ(completions.at(2)->error, asio::error::operation_aborted);
}

TEST(RingClient, SendsWaitForRoomInOrderAndFailBusyBeyondTheSendQueue) {
  IoThread io;
  Options options = test_options();
  options.node.pacing = trickle();  // one byte per second: the output queue stays full
  options.send_queue_bound = 2;
  options.send_timeout = 60000;
  Link link(io.executor(), options);
  constexpr std::size_t kSends = 20;
  Completions completions;
  for (std::size_t i = 0; i < kSends; ++i) {
    link.client->async_send(Message::drive(static_cast<std::int32_t>(i), 0), completions.send_handler(i));
  }
  // A receive queued after the sends completes after they were all accepted or refused (strand order).
  error_code barrier;
  (void)link.client->receive(0, barrier);
  EXPECT_EQ(barrier, RingError::receive_timed_out);
  const std::uint32_t originated = link.client->counters().ring.originated;
  ASSERT_GE(originated, 1u);
  ASSERT_LE(originated + 2, kSends);
  const std::size_t refused = kSends - originated - 2;
  ASSERT_TRUE(completions.wait_for(refused));
  // The first `originated` are in the node's queue, the next two wait in the send queue, the rest failed.
  for (std::size_t i = 0; i < kSends; ++i) {
    const auto outcome = completions.at(i);
    if (i < originated + 2) {
      EXPECT_FALSE(outcome.has_value()) << "send " << i;
    } else {
      ASSERT_TRUE(outcome.has_value()) << "send " << i;
      EXPECT_EQ(outcome->error, RingError::send_queue_full) << "send " << i;
    }
  }
  link.client->close();
  ASSERT_TRUE(completions.wait_for(kSends));
  for (std::size_t i = 0; i < originated + 2; ++i) EXPECT_EQ(completions.at(i)->error, asio::error::operation_aborted);
}

TEST(RingClient, SendThatFindsNoRoomInTimeFails) {
  IoThread io;
  Options options = test_options();
  options.node.pacing = trickle();
  options.send_queue_bound = 64;
  options.send_timeout = 150;
  auto clock = ManualClock::create();
  options.clock = clock;
  Link link(io.executor(), options);
  constexpr std::size_t kSends = 20;
  Completions completions;
  const Millis start = clock->now();
  for (std::size_t i = 0; i < kSends; ++i) {
    link.client->async_send(Message::drive(static_cast<std::int32_t>(i), 0), completions.send_handler(i));
  }
  error_code barrier;
  (void)link.client->receive(0, barrier);
  const std::uint32_t originated = link.client->counters().ring.originated;
  ASSERT_LT(originated, kSends);
  Millis due = 0;
  ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  EXPECT_EQ(completions.calls(), 0u);  // nothing failed before its send_timeout
  clock->advance_to(due);
  ASSERT_TRUE(completions.wait_for(kSends - originated));
  for (std::size_t i = originated; i < kSends; ++i) {
    EXPECT_EQ(completions.at(i)->error, RingError::send_timed_out) << "send " << i;
  }
}

// A device that stopped reading: the stream takes a few bytes and then none. Sends already handed to the
// node (their bytes queued behind the blocked write) fail at their `send_timeout` like those still waiting
// for room; a request whose bytes never reached the device says so instead of "no reply".
TEST(RingClient, SendsToADeviceThatStoppedReadingFailAtTheirSendTimeout) {
  IoThread io;
  Options options = test_options(200, 1000);
  options.send_timeout = 150;
  auto clock = ManualClock::create();
  options.clock = clock;
  // Nobody reads the other end; it holds 8 bytes, less than one drive message.
  auto [host_end, device_end] = transports::InMemoryStream::make_pair(io.executor(), 8);
  EventLog log;
  RingClient client(host_end, options, log.handler());
  constexpr std::size_t kSends = 3;
  Completions completions;
  const Millis start = clock->now();
  for (std::size_t i = 0; i < kSends; ++i) {
    client.async_send(Message::drive(static_cast<std::int32_t>(i), 0), completions.send_handler(i));
  }
  client.async_request(goal(1), Type::segment, completions.message_handler(kSends));
  error_code barrier;
  (void)client.receive(0, barrier);
  ASSERT_GE(client.counters().ring.originated, 1u);  // at least the first send was handed to the node
  Millis due = 0;
  ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  EXPECT_EQ(completions.calls(), 0u);
  clock->advance_to(static_cast<Millis>(start + 150));
  ASSERT_TRUE(completions.wait_for(kSends)) << completions.calls() << " of " << kSends << " sends completed";
  for (std::size_t i = 0; i < kSends; ++i) {
    EXPECT_EQ(completions.at(i)->error, RingError::send_timed_out) << "send " << i;
  }
  clock->advance_to(static_cast<Millis>(start + 1000));
  ASSERT_TRUE(completions.wait_for(kSends + 1));
  EXPECT_EQ(completions.at(kSends)->error, RingError::send_timed_out);
  client.close();
  device_end->close();
}

// --- receive -------------------------------------------------------------------------------------------

TEST(RingClient, ReceivesCapturedMessagesInOrder) {
  IoThread io;
  Options options = test_options();
  options.node.capture = TypeSet::of(Type::sensor);
  auto clock = ManualClock::create();
  options.clock = clock;
  Link link(io.executor(), options);
  // A receive made before the message arrives waits for it.
  std::future<Message> early = link.client->async_receive(asio::use_future);
  link.ring->send(wire(sensor(1)) + wire(sensor(2)) + wire(Message::drive(5, 5)) + wire(sensor(3)));
  ASSERT_EQ(early.wait_for(kPrompt), std::future_status::ready);
  EXPECT_TRUE(same(early.get(), sensor(1)));
  EXPECT_TRUE(same(link.client->receive(3000), sensor(2)));
  EXPECT_TRUE(same(link.client->receive(3000), sensor(3)));
  // The drive was not captured: forwarded.
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  EXPECT_TRUE(same(link.ring->messages()[0].message, Message::drive(5, 5)));
  // Nothing more: the timeout ends the wait; 0 means "only what is queued".
  const Millis start = clock->now();
  std::future<Message> none = link.client->async_receive(100, asio::use_future);
  Millis due = 0;
  ASSERT_TRUE(clock->wait_for_due(static_cast<Millis>(start + 100), due)) << "+" << due - start;
  clock->advance_to(due);
  ASSERT_EQ(none.wait_for(kPrompt), std::future_status::ready);
  try {
    none.get();
    ADD_FAILURE() << "expected receive_timed_out";
  } catch (const boost::system::system_error& failure) {
    EXPECT_EQ(failure.code(), RingError::receive_timed_out);
  }
  error_code error;
  (void)link.client->receive(0, error);
  EXPECT_EQ(error, RingError::receive_timed_out);
  EXPECT_EQ(link.client->counters().ring.captured, 3u);
}

TEST(RingClient, ReceiveQueueOverflowDropsTheOldestAndReportsIt) {
  IoThread io;
  Options options = test_options();
  options.node.capture = TypeSet::of(Type::sensor);
  options.receive_queue_bound = 2;
  Link link(io.executor(), options);
  link.ring->send(wire(sensor(1)) + wire(sensor(2)) + wire(sensor(3)) + wire(sensor(4)));
  ASSERT_TRUE(link.log.wait_for<events::ReceiveOverflow>(2));
  const auto reports = link.log.of<events::ReceiveOverflow>();
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_TRUE(same(reports[0].message, sensor(1)));
  EXPECT_TRUE(same(reports[1].message, sensor(2)));
  EXPECT_EQ(link.client->counters().receive_overflows, 2u);
  EXPECT_TRUE(same(link.client->receive(0), sensor(3)));
  EXPECT_TRUE(same(link.client->receive(0), sensor(4)));
}

TEST(RingClient, RequestClaimsItsReplyBeforeTheReceiveQueue) {
  IoThread io;
  Options options = test_options();
  options.node.capture = TypeSet::of(Type::segment);
  Link link(io.executor(), options, answer_goals_with_segment(8));
  link.ring->send(wire(segment(1)));  // before the request: received
  ASSERT_TRUE(eventually([&] { return link.client->counters().ring.captured == 1; }));
  EXPECT_TRUE(same(link.client->request(goal(1), Type::segment), segment(8)));
  EXPECT_TRUE(same(link.client->receive(0), segment(1)));
  error_code error;
  (void)link.client->receive(0, error);
  EXPECT_EQ(error, RingError::receive_timed_out);  // the reply was the request's only
}

TEST(RingClient, CaptureSetCanChange) {
  IoThread io;
  Link link(io.executor(), test_options());
  EXPECT_EQ(link.client->capture(), TypeSet());
  link.client->set_capture(TypeSet::of(Type::drive));
  EXPECT_EQ(link.client->capture(), TypeSet::of(Type::drive));
  link.ring->send(wire(Message::drive(1, 1)));
  EXPECT_TRUE(same(link.client->receive(3000), Message::drive(1, 1)));
  link.client->set_capture(TypeSet());
  link.ring->send(wire(Message::drive(2, 2)));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  EXPECT_TRUE(same(link.ring->messages()[0].message, Message::drive(2, 2)));
}

// --- forwarding ----------------------------------------------------------------------------------------

TEST(RingClient, UncapturedMessagesAreForwardedByteForByte) {
  IoThread io;
  Options options = on_steady_clock(test_options(20000, 40000));
  options.node.capture = TypeSet::of(Type::sensor);
  Link link(io.executor(), options);
  const std::string passing = "D{s50}{a25}\nG{n1}{b90}{p100,200}\nX{n4}{s160}{b80}{p3200,-64000}\n";
  link.ring->send(passing.substr(0, 12) + wire(sensor(1)) + passing.substr(12));
  link.ring->send("D{s 7} {a 8}\n");  // whitespace: stripped like the reference does
  ASSERT_TRUE(link.ring->wait_for_messages(4));
  EXPECT_EQ(link.ring->received(), passing + "D{s7}{a8}\n");
  const Counters counters = link.client->counters();
  EXPECT_EQ(counters.ring.forwarded, 4u);
  EXPECT_EQ(counters.ring.captured, 1u);
  EXPECT_TRUE(same(link.client->receive(0), sensor(1)));
}

TEST(RingClient, ForwardedAndOriginatedMessagesLeaveWhole) {
  IoThread io;
  Link link(io.executor(), on_steady_clock(test_options(20000, 40000)));
  Completions completions;
  for (int i = 0; i < 5; ++i) {
    link.ring->send(wire(goal(i)));
    link.client->async_send(Message::drive(i, i), completions.send_handler(static_cast<std::size_t>(i)));
  }
  ASSERT_TRUE(completions.wait_for(5));
  ASSERT_TRUE(link.ring->wait_for_messages(10));
  for (const auto& record : link.ring->messages()) EXPECT_TRUE(record.ok) << record.wire;
  EXPECT_EQ(count_of(link.ring->messages(), Type::goal), 5u);
  EXPECT_EQ(count_of(link.ring->messages(), Type::drive), 5u);
}

TEST(RingClient, ForwardingThatFindsTheQueueFullDropsAndReports) {
  IoThread io;
  Options options = test_options();
  options.node.pacing = trickle();
  Link link(io.executor(), options);
  constexpr std::size_t kMessages = 25;  // 25 x 14 bytes: more than the 255-byte queue
  std::string burst;
  for (std::size_t i = 0; i < kMessages; ++i) burst += wire(Message::drive(10 + static_cast<std::int32_t>(i), 25));
  link.ring->send(burst);
  ASSERT_TRUE(eventually([&] {
    const Counters c = link.client->counters();
    return c.ring.forwarded + c.ring.queue_full_drops == kMessages;
  }));
  const Counters counters = link.client->counters();
  EXPECT_GE(counters.ring.queue_full_drops, 1u);
  const auto reports = link.log.of<events::ForwardDropped>();
  ASSERT_EQ(reports.size(), counters.ring.queue_full_drops);
  // The last ones were dropped: the queue keeps the first in order.
  EXPECT_TRUE(same(reports.back().message, Message::drive(10 + static_cast<std::int32_t>(kMessages) - 1, 25)));
}

// --- reading the ring's bytes --------------------------------------------------------------------------

// What a client made of the ring's bytes: the messages it forwarded, its events, the messages it kept for
// receives, its counters.
struct Observed {
  std::string forwarded;
  std::vector<std::string> events;
  std::vector<std::string> received;
  LinkCounters link;
  RingCounters ring;
};

// Sends `traffic` (ending with a captured sensor, after `captured - 1` others) to a client whose stream holds
// `stream_capacity` bytes, and records what it made of it once every message was read.
Observed observe(const std::string& traffic, std::size_t captured, std::size_t forwarded,
                 std::size_t stream_capacity) {
  IoThread io;
  Options options = on_steady_clock(test_options(20000, 40000));
  options.node.capture = TypeSet::of(Type::sensor);
  options.node.partial_message_timeout = 600000;  // no partial message may time out under load
  options.receive_queue_bound = 2;
  Link link(io.executor(), options, {}, stream_capacity);
  link.ring->send(traffic);
  Observed observed;
  EXPECT_TRUE(eventually([&] { return link.client->counters().ring.captured == captured; }));
  EXPECT_TRUE(link.ring->wait_for_messages(forwarded));
  observed.forwarded = link.ring->received();
  for (const Event& event : link.log.all()) {
    if (const auto* dropped = std::get_if<events::InputDropped>(&event)) {
      observed.events.push_back(std::string("input dropped: ") + describe(dropped->error));
    } else if (const auto* overflow = std::get_if<events::ReceiveOverflow>(&event)) {
      observed.events.push_back("receive overflow: " + wire(overflow->message, Generation::d));
    } else {
      observed.events.push_back("other event " + std::to_string(event.index()));
    }
  }
  error_code error;
  for (Message message = link.client->receive(0, error); !error; message = link.client->receive(0, error)) {
    observed.received.push_back(wire(message, Generation::d));
  }
  observed.link = link.client->counters().link;
  observed.ring = link.client->counters().ring;
  return observed;
}

TEST(RingClient, ReceivedRunsGiveWhatTheSameBytesOneAtATimeGive) {
  // The client hands each received run to its node in one call up to every event; a stream of
  // one byte per read gives the byte-by-byte result. Captured sensors (more than the receive queue
  // holds), forwarded messages (one with whitespace, stripped), read errors of several kinds, a header
  // inside a message, a message longer than the reader holds, bytes between messages.
  const std::string too_long = [] {
    std::string text = "D";
    for (int i = 0; i < 30; ++i) text += "{s 1}";
    return text + "\n";
  }();
  const std::string traffic = wire(sensor(1)) + "D{s 7} {a 8}\n" + "G{n1}{z9}\n" + "X{n4}{s1" +
                              wire(Message::drive(5, 6)) + "junk\n" + wire(sensor(2)) + too_long +
                              "S{s 99999999999}\n" + wire(segment(3)) + "\r\n\n" + wire(sensor(3)) + "D{s1}{a}\n" +
                              wire(goal(4)) + wire(sensor(4));
  const Observed by_byte = observe(traffic, 4, 4, 1);
  const Observed by_run = observe(traffic, 4, 4, 4096);
  EXPECT_EQ(by_run.forwarded, by_byte.forwarded);
  EXPECT_EQ(by_byte.forwarded, "D{s7}{a8}\nD{s5}{a6}\nX{n3}{s160}{b80}{p3200,-64000}\nG{n4}{b90}{p100,200}\n");
  EXPECT_EQ(by_run.events, by_byte.events);
  const std::vector<std::string> events = {"input dropped: bad_attrib",
                                           "input dropped: bad_number",  // X{n4}{s1 cut by the next header
                                           "input dropped: bad_type",    // junk
                                           "input dropped: too_long",
                                           "input dropped: bad_number",  // beyond int32
                                           "receive overflow: " + wire(sensor(1), Generation::d),
                                           "input dropped: bad_number",  // {a} without digits
                                           "receive overflow: " + wire(sensor(2), Generation::d)};
  EXPECT_EQ(by_byte.events, events);
  EXPECT_EQ(by_run.received, by_byte.received);
  EXPECT_EQ(by_byte.received,
            (std::vector<std::string>{wire(sensor(3), Generation::d), wire(sensor(4), Generation::d)}));
  EXPECT_EQ(by_run.link.frames_ok, by_byte.link.frames_ok);
  EXPECT_EQ(by_run.link.framing_errors, by_byte.link.framing_errors);
  EXPECT_EQ(by_run.link.oversize_frames, by_byte.link.oversize_frames);
  EXPECT_EQ(by_run.link.resyncs, by_byte.link.resyncs);
  EXPECT_EQ(by_run.ring.captured, by_byte.ring.captured);
  EXPECT_EQ(by_run.ring.forwarded, by_byte.ring.forwarded);
}

// --- pacing --------------------------------------------------------------------------------------------

TEST(RingClient, WritesNeverRunAheadOfThePacer) {
  IoThread io;
  Options options = test_options();
  // A 16-byte receiver polled every 20 ms at 9600 baud: bucket of 8 bytes, 0.4 byte per ms.
  options.node.pacing.baud = 9600;
  options.node.pacing.receiver_buffer = 16;
  options.node.pacing.receiver_poll_interval = 20;
  const double depth = 8.0;
  const double rate = 0.4;
  options.send_timeout = 1000000000;  // waiting for room never times out here: only pacing is measured
  auto clock = ManualClock::create();
  options.clock = clock;
  const Millis start = clock->now();  // the pacer's bucket starts full
  Link link(io.executor(), options);
  link.ring->use_clock(clock);
  constexpr std::size_t kSends = 12;
  Completions completions;
  std::size_t total = 0;
  for (std::size_t i = 0; i < kSends; ++i) {
    const Message message = Message::drive(static_cast<std::int32_t>(100 + i), 25);
    total += wire(message).size();
    link.client->async_send(message, completions.send_handler(i));
  }
  // In steps of at most 5 ms: the pacer's next wakeup is armed only once a write completed.
  ASSERT_TRUE(clock->advance_until([&] { return completions.calls() == kSends; }, 20000ms, 5));
  for (std::size_t i = 0; i < kSends; ++i) EXPECT_FALSE(completions.at(i)->error) << "send " << i;
  ASSERT_TRUE(link.ring->wait_for_messages(kSends));
  // However late a read completes, the bytes it brings were written before it: by then (simulated time)
  // the pacer allowed at most its bucket plus what refilled since the start.
  std::size_t received = 0;
  for (const Arrival& arrival : link.ring->arrivals()) {
    received += arrival.bytes;
    const auto ms = static_cast<double>(tick_difference(arrival.at, start));
    EXPECT_LE(static_cast<double>(received), depth + rate * ms) << "after " << ms << " ms";
  }
  EXPECT_EQ(received, total);
  EXPECT_GE(static_cast<double>(tick_difference(clock->now(), start)), (static_cast<double>(total) - depth) / rate);
  // In order, whole.
  const auto records = link.ring->messages();
  for (std::size_t i = 0; i < kSends; ++i) {
    EXPECT_TRUE(same(records[i].message, Message::drive(static_cast<std::int32_t>(100 + i), 25))) << "message " << i;
  }
  EXPECT_EQ(link.client->counters().bytes_written, total);
}

// --- broken input --------------------------------------------------------------------------------------

TEST(RingClient, PartialMessageIsDroppedAtItsDeadline) {
  IoThread io;
  Options options = on_steady_clock(test_options(20000, 40000));  // the 50 ms partial deadline passes in real time
  options.node.partial_message_timeout = 50;
  Link link(io.executor(), options);
  link.ring->send("D{s 5");
  ASSERT_TRUE(link.log.wait_for<events::InputDropped>());
  const auto reports = link.log.of<events::InputDropped>();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].error, Error::timed_out);
  EXPECT_EQ(link.client->counters().link.partial_timeouts, 1u);
  // The reader resynchronised: the next message passes.
  link.ring->send(wire(Message::drive(6, 6)));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  EXPECT_TRUE(same(link.ring->messages()[0].message, Message::drive(6, 6)));
}

TEST(RingClient, ReadErrorsAreReportedAndNotForwarded) {
  IoThread io;
  Link link(io.executor(), test_options());
  link.ring->send("Q{s 1}\nD{s 1}{z 2}\n" + wire(Message::drive(3, 3)));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  EXPECT_EQ(link.ring->received(), "D{s3}{a3}\n");
  const auto reports = link.log.of<events::InputDropped>();
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].error, Error::bad_type);
  EXPECT_EQ(reports[1].error, Error::bad_attrib);
}

// --- generation D --------------------------------------------------------------------------------------

TEST(RingClient, GenerationDRequestsForwardsAndChecksTheCrc) {
  IoThread io;
  Options options = on_steady_clock(test_options(20000, 40000));
  options.node.generation = Generation::d;
  Link link(io.executor(), options, answer_goals_with_segment(4, Generation::d));
  const Message reply = link.client->request(goal(1), Type::segment);
  EXPECT_TRUE(same(reply, segment(4)));
  auto records = link.ring->messages();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].wire, wire(goal(1), Generation::d));
  EXPECT_EQ(records[0].wire.rfind("G{n1}{b90}{p100}{q200}", 0), 0u);  // no spaces, p and q, CRC trailer

  // Forwarded byte-identical (the CRC stays valid); a damaged CRC is dropped and reported.
  const std::string passing = wire(Message::drive(50, 25), Generation::d);
  std::string damaged = wire(Message::drive(51, 25), Generation::d);
  damaged[damaged.size() - 2] = damaged[damaged.size() - 2] == '0' ? '1' : '0';
  link.ring->send(damaged + passing);
  ASSERT_TRUE(link.ring->wait_for_messages(2));
  records = link.ring->messages();
  EXPECT_EQ(records[1].wire, passing);
  EXPECT_EQ(link.ring->received(), wire(goal(1), Generation::d) + passing);
  const auto reports = link.log.of<events::InputDropped>();
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].error, Error::bad_crc);
  EXPECT_EQ(link.client->counters().link.crc_errors, 1u);
}

TEST(RingClient, GenerationDUndeliverableRequestFailsFast) {
  IoThread io;
  Options options = test_options(20000, 40000);
  options.node.generation = Generation::d;
  Link link(io.executor(), options, echo_goals());
  error_code error;
  (void)link.client->request(goal(2), Type::segment, error);
  EXPECT_EQ(error, RingError::undeliverable);
  EXPECT_EQ(link.client->counters().ring.undeliverable, 1u);
}

// --- rejected before the wire --------------------------------------------------------------------------

TEST(RingClient, InvalidMessagesAreRejectedBeforeTheWire) {
  IoThread io;
  Link link(io.executor(), test_options());
  Message incomplete;
  incomplete.type = Type::drive;
  incomplete.speed = 5;  // no angle
  error_code error;
  link.client->send(incomplete, error);
  EXPECT_EQ(error, RingError::invalid_message);
  EXPECT_EQ(error, boost::system::errc::invalid_argument);
  (void)link.client->request(incomplete, Type::segment, error);
  EXPECT_EQ(error, RingError::invalid_message);
  (void)link.client->request(goal(1), static_cast<Type>('Z'), error);
  EXPECT_EQ(error, RingError::invalid_reply_type);
  Message unknown = Message::drive(1, 1);
  unknown.type = static_cast<Type>('Q');
  EXPECT_THROW(link.client->send(unknown), boost::system::system_error);
  link.client->send(Message::drive(1, 1));  // the wire carries only this
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  EXPECT_EQ(link.ring->received(), wire(Message::drive(1, 1)));
}

// --- cancellation ----------------------------------------------------------------------------------------

TEST(RingClient, CancellingOneOperationLeavesTheOthersAlone) {
  IoThread io;
  auto clock = ManualClock::create();
  Options options = test_options(200, 2000, clock);  // no re-send unless the test moves the clock
  options.node.capture = TypeSet::of(Type::sensor);
  Link link(io.executor(), options);  // nobody answers
  Completions completions;
  client::CancellationSignal cancel_request, cancel_receive;
  link.client->async_request(goal(1), Type::segment,
                             client::bind_cancellation(cancel_request, completions.message_handler(0)));
  link.client->async_receive(client::bind_cancellation(cancel_receive, completions.message_handler(1)));
  link.client->async_receive(completions.message_handler(2));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  cancel_request.emit();
  ASSERT_TRUE(completions.wait_for(1));
  EXPECT_EQ(completions.at(0)->error, asio::error::operation_aborted);
  cancel_receive.emit();
  ASSERT_TRUE(completions.wait_for(2));
  EXPECT_EQ(completions.at(1)->error, asio::error::operation_aborted);
  // The other receive still waits: it gets the next captured message.
  link.ring->send(wire(sensor(4)));
  ASSERT_TRUE(completions.wait_for(3));
  EXPECT_FALSE(completions.at(2)->error);
  EXPECT_TRUE(same(*completions.at(2)->message, sensor(4)));
  // The cancelled request's reply type is no longer captured: its late reply goes on round the ring.
  link.ring->send(wire(segment(5)));
  ASSERT_TRUE(clock->advance_until([&] { return link.ring->messages().size() >= 2; }));  // paced
  EXPECT_TRUE(same(link.ring->messages()[1].message, segment(5)));
  EXPECT_EQ(count_of(link.ring->messages(), Type::goal), 1u);  // never re-sent
  EXPECT_EQ(link.client->counters().replies, 0u);
}

// --- close and link failure ----------------------------------------------------------------------------

TEST(RingClient, CloseCompletesEveryPendingOperationWithOperationAborted) {
  IoThread io;
  Options options = test_options(20000, 40000);
  options.node.pacing = trickle();
  Link link(io.executor(), options);
  Completions completions;
  link.client->async_request(goal(1), Type::segment, completions.message_handler(0));  // in flight
  link.client->async_receive(completions.message_handler(1));                          // waiting
  link.client->async_send(Message::drive(1, 1), completions.send_handler(2));          // being written
  error_code barrier;
  (void)link.client->receive(0, barrier);  // every operation above was accepted
  EXPECT_EQ(completions.calls(), 0u);
  link.client->close();
  ASSERT_TRUE(completions.wait_for(3));
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(completions.at(i)->error, asio::error::operation_aborted) << i;
  EXPECT_FALSE(link.client->is_open());
  // Later operations fail the same way.
  error_code error;
  link.client->send(Message::drive(1, 1), error);
  EXPECT_EQ(error, asio::error::operation_aborted);
  (void)link.client->request(goal(1), Type::segment, error);
  EXPECT_EQ(error, asio::error::operation_aborted);
  (void)link.client->receive(1000, error);
  EXPECT_EQ(error, asio::error::operation_aborted);
}

TEST(RingClient, LinkFailureFailsPendingOperationsAndIsReported) {
  IoThread io;
  Link link(io.executor(), test_options(20000, 40000));
  Completions completions;
  link.client->async_request(goal(1), Type::segment, completions.message_handler(0));
  ASSERT_TRUE(link.ring->wait_for_messages(1));
  link.ring->close();
  ASSERT_TRUE(completions.wait_for(1));
  EXPECT_TRUE(completions.at(0)->error);
  EXPECT_NE(completions.at(0)->error, asio::error::operation_aborted);
  ASSERT_TRUE(link.log.wait_for<events::LinkFailed>());
  EXPECT_EQ(link.log.of<events::LinkFailed>()[0].error, completions.at(0)->error);
  error_code error;
  link.client->send(Message::drive(1, 1), error);
  EXPECT_EQ(error, completions.at(0)->error);  // the link's error, for every later operation
}

TEST(RingClient, BlockingCallFromTheStrandFailsInsteadOfDeadlocking) {
  IoThread io;
  Options options = test_options();
  auto [host_end, ring_end] = transports::InMemoryStream::make_pair(io.executor());
  auto ring = FakeRing::start(ring_end, Generation::b);
  std::promise<error_code> seen;
  RingClient* client_ptr = nullptr;
  std::atomic<bool> once{false};
  RingClient client(host_end, options, [&](const Event&) {
    if (once.exchange(true)) return;
    error_code error;
    client_ptr->send(Message::drive(1, 1), error);
    seen.set_value(error);
  });
  client_ptr = &client;
  ring->send("Q\n");  // a read error: an event
  auto future = seen.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(future.get(), transports::TransportError::would_deadlock);
  client.close();
  ring->close();
}

// --- options and errors --------------------------------------------------------------------------------

TEST(RingClient, InvalidOptionsAreRefused) {
  IoThread io;
  auto [host_end, ring_end] = transports::InMemoryStream::make_pair(io.executor());
  EXPECT_THROW({ RingClient client(nullptr); }, std::invalid_argument);
  Options options;
  options.receive_queue_bound = 0;
  EXPECT_THROW({ RingClient client(host_end, options); }, std::invalid_argument);
  options = Options();
  options.timing.max_attempts = 0;
  EXPECT_THROW({ RingClient client(host_end, options); }, std::invalid_argument);
  options = Options();
  options.timing.call_budget = 0;
  EXPECT_THROW({ RingClient client(host_end, options); }, std::invalid_argument);
  ring_end->close();
}

TEST(RingError, EveryCodeHasAMessageAndACondition) {
  for (int value = 1; value <= static_cast<int>(RingError::invalid_reply_type); ++value) {
    const error_code error = make_error_code(static_cast<RingError>(value));
    EXPECT_STREQ(error.category().name(), "tether.elcano");
    EXPECT_NE(error.message().find(' '), std::string::npos) << value;
    EXPECT_EQ(error.message().find("unknown"), std::string::npos) << value;
  }
  EXPECT_EQ(error_code(RingError::send_timed_out), boost::system::errc::timed_out);
  EXPECT_EQ(error_code(RingError::receive_timed_out), boost::system::errc::timed_out);
  EXPECT_EQ(error_code(RingError::send_queue_full), boost::system::errc::device_or_resource_busy);
  EXPECT_NE(error_code(RingError::undeliverable), boost::system::errc::timed_out);
}

}  // namespace
}  // namespace tether::elcano::testing
