// The proxy's session policy (session_policy.hpp) driven through the session engine with a fake clock
// (plain integers as `now`): the ack timeout formula, re-sends of a silent message with the same id, the
// budget and max_sends bounds, acks completing messages, stale acks.
#include "tether/proxy/session_policy.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace tether::proxy {
namespace {

// Polls `table` at every millisecond from `from` to `to` (inclusive); the times of the re-sends and the
// completion, if any.
struct Polled {
  std::vector<Millis> resends;
  bool completed = false;
  Millis completed_at = 0;
  RequestTable::Completion completion;
};

Polled poll_until(RequestTable& table, Millis from, Millis to) {
  Polled polled;
  for (Millis now = from; now <= to && !polled.completed; ++now) {
    for (RequestTable::Step step = table.poll(now); step.action != RequestTable::Action::idle; step = table.poll(now)) {
      if (step.action == RequestTable::Action::resend) polled.resends.push_back(now);
      if (step.action == RequestTable::Action::complete) {
        polled.completed = true;
        polled.completed_at = now;
        polled.completion = step.completion;
        break;
      }
    }
  }
  return polled;
}

TEST(ProxySessionPolicy, AckTimeoutIsBothFramesOnTheWirePlusTheMargin) {
  EXPECT_EQ(kAckFrameBytes, 16u);  // ArduinoOut{ack{messageId, refused}}: 11 payload bytes, CRC, COBS, two delimiters
  const AckTiming timing;  // 115200 baud, 11 bits per byte, 50 ms margin
  // (20 + 16) * 11 bits = 396 bits -> 3.44 ms, rounded up to 4, + 50.
  EXPECT_EQ(ack_timeout(timing, 20), 54u);
  AckTiming slow = timing;
  slow.baud = 57600;
  EXPECT_EQ(ack_timeout(slow, 20), 57u);  // 6.88 ms -> 7, + 50
  AckTiming absurd = timing;
  absurd.baud = 1;
  absurd.bits_per_byte = 0xFFFFFFFFu;
  EXPECT_EQ(ack_timeout(absurd, 1000), 0x7FFFFFFFu);  // saturated, never wrapped
}

TEST(ProxySessionPolicy, CallTimingResendsOnSilenceAndNeverOnAnAck) {
  AckTiming timing;
  timing.send_budget = 800;
  timing.max_sends = 9;
  const session::CallTiming call = call_timing(timing, 20);
  EXPECT_EQ(call.attempt_timeout, 54u);
  EXPECT_EQ(call.call_budget, 800u);
  EXPECT_EQ(call.max_attempts, 9);
  EXPECT_TRUE(call.retry_on_timeout);
  EXPECT_FALSE(call.activity_rearms_attempt);
  EXPECT_TRUE(SessionPolicy::is_success(0));
  EXPECT_FALSE(SessionPolicy::is_retryable(0));
}

TEST(ProxySessionPolicy, ASilentMessageIsResentEachWindowWithTheSameIdUntilItsAck) {
  LinkCounters counters;
  RequestTable table(call_timing(AckTiming(), 20), 0, counters);
  ASSERT_TRUE(table.begin_with(0xDEADBEEFu, 1000).ok());
  const Polled silent = poll_until(table, 1000, 1120);
  EXPECT_EQ(silent.resends, (std::vector<Millis>{1054, 1108}));
  EXPECT_FALSE(silent.completed);
  const RequestTable::ReplyResult acked = table.on_reply(0xDEADBEEFu, 0, 1121);
  ASSERT_EQ(acked.verdict, RequestTable::Verdict::completed);
  EXPECT_EQ(acked.completion.outcome, session::CallOutcome::ok);
  EXPECT_EQ(acked.completion.attempts, 3);
  EXPECT_EQ(counters.retries, 2u);
  EXPECT_EQ(table.in_flight(), 0);
}

TEST(ProxySessionPolicy, TheBudgetEndsTheResendsFromTheFirstSend) {
  LinkCounters counters;
  RequestTable table(call_timing(AckTiming(), 20), 0, counters);  // 54 ms windows, 1 s budget
  ASSERT_TRUE(table.begin_with(7, 0).ok());
  const Polled polled = poll_until(table, 0, 2000);
  ASSERT_TRUE(polled.completed);
  EXPECT_EQ(polled.completed_at, 1000u);
  EXPECT_EQ(polled.completion.outcome, session::CallOutcome::timeout);
  EXPECT_EQ(polled.resends.size(), 18u);  // at 54, 108, ..., 972
  EXPECT_EQ(polled.completion.attempts, 19);
  EXPECT_EQ(counters.timeouts, 1u);
}

TEST(ProxySessionPolicy, MaxSendsBoundsTheFramesOfOneMessage) {
  LinkCounters counters;
  AckTiming timing;
  timing.max_sends = 3;
  RequestTable table(call_timing(timing, 20), 0, counters);
  ASSERT_TRUE(table.begin_with(7, 0).ok());
  const Polled polled = poll_until(table, 0, 2000);
  EXPECT_EQ(polled.resends, (std::vector<Millis>{54, 108}));
  ASSERT_TRUE(polled.completed);
  EXPECT_EQ(polled.completed_at, 162u);  // the third window ends: no fourth frame
  EXPECT_EQ(polled.completion.outcome, session::CallOutcome::timeout);
  EXPECT_EQ(polled.completion.attempts, 3);
}

TEST(ProxySessionPolicy, AnAckOfAnIdNotInFlightIsStale) {
  // A duplicate ack of a re-sent message, or a late one: counted, dropped, never given to another message.
  LinkCounters counters;
  RequestTable table(call_timing(AckTiming(), 20), 0, counters);
  ASSERT_TRUE(table.begin_with(7, 0).ok());
  EXPECT_EQ(table.on_reply(8, 0, 10).verdict, RequestTable::Verdict::stale);
  EXPECT_EQ(counters.stale, 1u);
  EXPECT_TRUE(table.contains(7));
  EXPECT_EQ(table.on_reply(7, 0, 11).verdict, RequestTable::Verdict::completed);
  EXPECT_EQ(table.on_reply(7, 0, 12).verdict, RequestTable::Verdict::stale);  // the same ack again
  EXPECT_EQ(counters.stale, 2u);
}

TEST(ProxySessionPolicy, EightMessagesFlyAtOnce) {
  LinkCounters counters;
  RequestTable table(call_timing(AckTiming(), 20), 0, counters);
  for (uint32_t id = 1; id <= kMaxInFlight; ++id) ASSERT_TRUE(table.begin_with(id, 0).ok());
  EXPECT_EQ(table.begin_with(100, 0).status(), Status::busy);
}

}  // namespace
}  // namespace tether::proxy
