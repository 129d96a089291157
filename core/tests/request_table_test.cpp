// Host half of the session engine: one test per rule of request_table.hpp, with a fake clock (plain
// integers passed as `now`) and scripted replies.
#include "tether/core/session/request_table.hpp"

#include <gtest/gtest.h>

#include <set>

namespace tether::session {
namespace {

// Romi-like policy: 8-bit ids, code 0 is success, envelope errors -1..-6 are retryable.
struct RomiLikePolicy {
  using Id = uint8_t;
  using Code = int16_t;
  static bool is_success(Code code) { return code >= 0; }
  static bool is_retryable(Code code) { return code <= -1 && code >= -6; }
};

// Proxy-like policy: 32-bit ids, an ack (code 0) is the only reply.
struct AckPolicy {
  using Id = uint32_t;
  using Code = uint8_t;
  static bool is_success(Code) { return true; }
  static bool is_retryable(Code) { return false; }
};

CallTiming romi_timing() {
  CallTiming timing;
  timing.attempt_timeout = 1000;
  timing.call_budget = 2000;
  timing.max_attempts = 3;
  timing.retry_on_timeout = false;
  timing.activity_rearms_attempt = true;
  return timing;
}

CallTiming ack_timing() {
  CallTiming timing;
  timing.attempt_timeout = 100;
  timing.call_budget = 1000;
  timing.max_attempts = 5;
  timing.retry_on_timeout = true;
  return timing;
}

using RomiTable = RequestTable<RomiLikePolicy, 1>;
using AckTable = RequestTable<AckPolicy, 4>;

TEST(RequestTable, RomiIdsStartAfter255AndWrapMod256) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  for (int expected = 0; expected < 600; ++expected) {
    const auto id = table.begin(static_cast<Millis>(expected));
    ASSERT_TRUE(id.ok());
    ASSERT_EQ(id.value(), static_cast<uint8_t>(expected));
    ASSERT_EQ(table.on_reply(id.value(), 0, static_cast<Millis>(expected)).verdict, RomiTable::Verdict::completed);
  }
}

TEST(RequestTable, ThirtyTwoBitIdsWrap) {
  LinkCounters counters;
  AckTable table(ack_timing(), 0xFFFFFFFEu, counters);
  EXPECT_EQ(table.begin(0).value(), 0xFFFFFFFFu);
  EXPECT_EQ(table.begin(0).value(), 0u);
}

TEST(RequestTable, ThirtyTwoBitIdInFlightIsSkipped) {
  LinkCounters counters;
  AckTable table(ack_timing(), 0xFFFFFFFEu, counters);  // the sequence would hand out 0xFFFFFFFF next ...
  ASSERT_EQ(table.begin_with(0xFFFFFFFFu, 0).value(), 0xFFFFFFFFu);
  EXPECT_EQ(table.begin(0).value(), 0u);  // ... but it is in flight, so the sequence moves on
  EXPECT_EQ(table.begin_with(0u, 0).status(), Status::busy);
}

TEST(RequestTable, EightBitIdInFlightIsSkippedAfterAFullLap) {
  LinkCounters counters;
  RequestTable<RomiLikePolicy, 2> table(romi_timing(), 255, counters);
  const uint8_t held = table.begin(0).value();  // id 0 stays in flight
  for (int i = 1; i < 256; ++i) {
    const auto id = table.begin(0);
    ASSERT_TRUE(id.ok());
    ASSERT_NE(id.value(), held);
    table.on_reply(id.value(), 0, 0);
  }
  const auto lapped = table.begin(0);
  ASSERT_TRUE(lapped.ok());
  EXPECT_EQ(lapped.value(), 1);  // 0 skipped
}

TEST(RequestTable, FullTableIsBusy) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  ASSERT_TRUE(table.begin(0).ok());
  const auto second = table.begin(0);
  EXPECT_FALSE(second.ok());
  EXPECT_EQ(second.status(), Status::busy);
}

TEST(RequestTable, SuccessCompletesOkOnce) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  const auto first = table.on_reply(id, 0, 10);
  ASSERT_EQ(first.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(first.completion.outcome, CallOutcome::ok);
  EXPECT_EQ(first.completion.attempts, 1);
  // The same reply again is stale: a call is completed exactly once.
  EXPECT_EQ(table.on_reply(id, 0, 11).verdict, RomiTable::Verdict::stale);
  EXPECT_EQ(table.poll(5000).action, RomiTable::Action::idle);
  EXPECT_EQ(counters.stale, 1u);
}

TEST(RequestTable, RetryableCodeResendsSameIdUntilAttemptsRunOut) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  EXPECT_EQ(table.on_reply(id, -4, 10).verdict, RomiTable::Verdict::resend);
  EXPECT_EQ(table.attempts(id), 2);
  EXPECT_EQ(table.on_reply(id, -4, 20).verdict, RomiTable::Verdict::resend);
  EXPECT_EQ(table.attempts(id), 3);
  const auto last = table.on_reply(id, -4, 30);  // third attempt failed too: the error goes to the caller
  ASSERT_EQ(last.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(last.completion.outcome, CallOutcome::remote_error);
  EXPECT_EQ(last.completion.code, -4);
  EXPECT_EQ(last.completion.attempts, 3);
  EXPECT_EQ(counters.retries, 2u);
}

TEST(RequestTable, NonRetryableCodeIsDeliveredWithoutResend) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  const auto result = table.on_reply(id, -16, 10);  // unknown opcode: re-sending cannot help
  ASSERT_EQ(result.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(result.completion.outcome, CallOutcome::remote_error);
  EXPECT_EQ(result.completion.code, -16);
  EXPECT_EQ(counters.retries, 0u);
}

TEST(RequestTable, ApplicationErrorCodesAreNotRetried) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  // Positive codes are the application's; with this policy they count as replies, delivered as-is.
  const auto result = table.on_reply(id, 101, 10);
  ASSERT_EQ(result.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(result.completion.code, 101);
}

TEST(RequestTable, NoRetryOnceTheBudgetIsSpent) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  const auto result = table.on_reply(id, -4, 2000);  // retryable, but the 2 s budget is gone
  ASSERT_EQ(result.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(result.completion.outcome, CallOutcome::remote_error);
}

TEST(RequestTable, SilentAttemptTimesOutAfterAttemptTimeoutWithoutRetryWhenPolicySaysSo) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t id = table.begin(0).value();
  EXPECT_EQ(table.poll(999).action, RomiTable::Action::idle);
  const auto step = table.poll(1000);
  ASSERT_EQ(step.action, RomiTable::Action::complete);
  EXPECT_EQ(step.id, id);
  EXPECT_EQ(step.completion.outcome, CallOutcome::timeout);
  EXPECT_EQ(step.completion.attempts, 1);
  EXPECT_EQ(counters.timeouts, 1u);
  EXPECT_EQ(counters.retries, 0u);
}

TEST(RequestTable, ActivityRearmsTheAttemptButNeverPastTheBudget) {
  // Romi: log lines and stale frames keep the 1 s read window open, but one call never exceeds 2 s.
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  table.begin(0);
  table.on_activity(900);  // a log line: window now ends at 1900
  EXPECT_EQ(table.poll(1899).action, RomiTable::Action::idle);
  table.on_activity(1800);  // another one: the window would end at 2800, the budget ends at 2000
  EXPECT_EQ(table.next_wakeup().at(), 2000u);
  EXPECT_EQ(table.poll(1999).action, RomiTable::Action::idle);
  const auto step = table.poll(2000);
  ASSERT_EQ(step.action, RomiTable::Action::complete);
  EXPECT_EQ(step.completion.outcome, CallOutcome::timeout);
}

TEST(RequestTable, StaleRepliesDuringACallKeepItAliveAndAreCounted) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t late = table.begin(0).value();
  ASSERT_EQ(table.poll(1000).completion.outcome, CallOutcome::timeout);
  const uint8_t current = table.begin(1000).value();
  ASSERT_NE(late, current);
  // The late answer to the first call arrives during the second: stale, never delivered to the second.
  const auto stale = table.on_reply(late, 0, 1500);
  EXPECT_EQ(stale.verdict, RomiTable::Verdict::stale);
  table.on_activity(1500);
  EXPECT_TRUE(table.contains(current));
  EXPECT_EQ(counters.stale, 1u);
  const auto own = table.on_reply(current, 0, 1600);
  ASSERT_EQ(own.verdict, RomiTable::Verdict::completed);
  EXPECT_EQ(own.completion.id, current);
}

TEST(RequestTable, StaleErrorRepliesAreNotPinnedOnTheCurrentCall) {
  // Regression guard for the reference host's defect B4: an error frame with another id is stale too.
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const uint8_t current = table.begin(0).value();
  EXPECT_EQ(table.on_reply(static_cast<uint8_t>(current + 7), -16, 10).verdict, RomiTable::Verdict::stale);
  EXPECT_TRUE(table.contains(current));
}

TEST(RequestTable, TimeoutRetriesResendUntilAcked) {
  LinkCounters counters;
  AckTable table(ack_timing(), 41, counters);
  const uint32_t id = table.begin(0).value();
  ASSERT_EQ(id, 42u);
  auto step = table.poll(100);
  ASSERT_EQ(step.action, AckTable::Action::resend);
  EXPECT_EQ(step.id, id);  // same id on a re-send
  step = table.poll(200);
  ASSERT_EQ(step.action, AckTable::Action::resend);
  EXPECT_EQ(table.attempts(id), 3);
  const auto ack = table.on_reply(id, 0, 250);
  ASSERT_EQ(ack.verdict, AckTable::Verdict::completed);
  EXPECT_EQ(ack.completion.outcome, CallOutcome::ok);
  EXPECT_EQ(ack.completion.attempts, 3);
  EXPECT_EQ(counters.retries, 2u);
}

TEST(RequestTable, BudgetExhaustedGivesTimeoutWithinBudget) {
  CallTiming timing = ack_timing();
  timing.attempt_timeout = 300;
  timing.call_budget = 1000;
  timing.max_attempts = 100;  // attempts never run out: the budget must end the call
  LinkCounters counters;
  AckTable table(timing, 0, counters);
  const uint32_t id = table.begin(0).value();
  Millis now = 0;
  int resends = 0;
  for (;;) {
    const Deadline wake = table.next_wakeup();
    ASSERT_TRUE(wake.armed());
    now = wake.at();
    const auto step = table.poll(now);
    if (step.action == AckTable::Action::resend) {
      ++resends;
      continue;
    }
    ASSERT_EQ(step.action, AckTable::Action::complete);
    EXPECT_EQ(step.id, id);
    EXPECT_EQ(step.completion.outcome, CallOutcome::timeout);
    break;
  }
  EXPECT_EQ(now, 1000u);  // exactly at the budget, not one attempt later
  EXPECT_EQ(resends, 3);  // sends at 0, 300, 600, 900
  EXPECT_EQ(table.in_flight(), 0);
}

TEST(RequestTable, AttemptsRunOutBeforeBudget) {
  CallTiming timing = ack_timing();
  timing.max_attempts = 2;
  LinkCounters counters;
  AckTable table(timing, 0, counters);
  table.begin(0);
  ASSERT_EQ(table.poll(100).action, AckTable::Action::resend);
  const auto step = table.poll(200);
  ASSERT_EQ(step.action, AckTable::Action::complete);
  EXPECT_EQ(step.completion.outcome, CallOutcome::timeout);
  EXPECT_EQ(step.completion.attempts, 2);
}

TEST(RequestTable, CancelCompletesOnceAndLaterReplyIsStale) {
  LinkCounters counters;
  AckTable table(ack_timing(), 0, counters);
  const uint32_t id = table.begin(0).value();
  const auto cancelled = table.cancel(id);
  ASSERT_TRUE(cancelled.ok());
  EXPECT_EQ(cancelled.value().outcome, CallOutcome::cancelled);
  EXPECT_EQ(table.cancel(id).status(), Status::not_found);
  EXPECT_EQ(table.on_reply(id, 0, 5).verdict, AckTable::Verdict::stale);
  EXPECT_EQ(table.poll(10000).action, AckTable::Action::idle);
}

TEST(RequestTable, ConcurrentCallsCompleteIndependentlyExactlyOnce) {
  LinkCounters counters;
  AckTable table(ack_timing(), 0, counters);
  std::set<uint32_t> ids;
  for (int i = 0; i < 4; ++i) ids.insert(table.begin(0).value());
  ASSERT_EQ(ids.size(), 4u);
  EXPECT_FALSE(table.begin(0).ok());
  std::multiset<uint32_t> completed;
  // Replies out of order, one duplicated, one call left to time out.
  const uint32_t a = *ids.begin();
  const uint32_t b = *std::next(ids.begin());
  const uint32_t c = *std::next(ids.begin(), 2);
  for (uint32_t id : {c, a, c, b}) {
    const auto result = table.on_reply(id, 0, 50);
    if (result.verdict == AckTable::Verdict::completed) completed.insert(result.completion.id);
  }
  Millis now = 0;
  while (table.in_flight() > 0) {
    now = table.next_wakeup().at();
    const auto step = table.poll(now);
    if (step.action == AckTable::Action::complete) completed.insert(step.id);
  }
  EXPECT_EQ(completed.size(), 4u);
  for (uint32_t id : ids) EXPECT_EQ(completed.count(id), 1u) << id;
  EXPECT_EQ(counters.stale, 1u);
}

TEST(RequestTable, DeadlinesWorkAcrossTheClockWrap) {
  LinkCounters counters;
  RomiTable table(romi_timing(), 255, counters);
  const Millis start = 0xFFFFFE00u;
  table.begin(start);
  EXPECT_EQ(table.poll(static_cast<Millis>(start + 999)).action, RomiTable::Action::idle);
  EXPECT_EQ(table.poll(static_cast<Millis>(start + 1000)).action, RomiTable::Action::complete);
}

}  // namespace
}  // namespace tether::session
