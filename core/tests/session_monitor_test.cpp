#include "tether/core/session/session_monitor.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace tether::session {
namespace {

using Monitor = SessionMonitor<uint32_t, 8>;

// Collects every action until `none`, as strings, e.g. {"reset", "init 3", "established"}.
std::vector<std::string> drain(Monitor& monitor, Millis now) {
  std::vector<std::string> actions;
  for (;;) {
    const Monitor::Action action = monitor.poll(now);
    switch (action.kind) {
      case Monitor::ActionKind::none: return actions;
      case Monitor::ActionKind::send_reset: actions.push_back("reset"); break;
      case Monitor::ActionKind::reset_detected: actions.push_back("detected"); break;
      case Monitor::ActionKind::replay_init: actions.push_back("init " + std::to_string(action.key)); break;
      case Monitor::ActionKind::established: actions.push_back("established"); break;
    }
  }
}

SessionTiming timing() {
  SessionTiming result;
  result.reset_timeout = 500;
  return result;
}

TEST(SessionMonitor, StartSendsResetAndWaitsForResetEvent) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  EXPECT_TRUE(drain(monitor, 0).empty());  // idle until started
  monitor.start(0);
  EXPECT_EQ(drain(monitor, 0), (std::vector<std::string>{"reset"}));
  EXPECT_TRUE(drain(monitor, 100).empty());
  EXPECT_EQ(monitor.state(), SessionState::awaiting_reset_event);
  EXPECT_FALSE(monitor.has_session());
}

TEST(SessionMonitor, ResetEventStoresIdAndReplaysInitsInOrder) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  ASSERT_EQ(monitor.register_init(7), Status::ok);
  ASSERT_EQ(monitor.register_init(3), Status::ok);
  ASSERT_EQ(monitor.register_init(5), Status::ok);
  ASSERT_EQ(monitor.register_init(3), Status::ok);  // registered again: keeps its place
  monitor.start(0);
  drain(monitor, 0);
  monitor.on_reset_event(0xABCD, 40);
  EXPECT_EQ(drain(monitor, 40), (std::vector<std::string>{"init 7", "init 3", "init 5", "established"}));
  EXPECT_EQ(monitor.state(), SessionState::established);
  EXPECT_EQ(monitor.session_id(), 0xABCDu);
  EXPECT_EQ(counters.resets, 0u);  // the handshake we asked for is not a detected reset
}

TEST(SessionMonitor, UnansweredResetIsSentAgainAfterTimeout) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  monitor.start(0);
  ASSERT_EQ(drain(monitor, 0), (std::vector<std::string>{"reset"}));
  EXPECT_TRUE(drain(monitor, 499).empty());
  EXPECT_EQ(monitor.next_wakeup().at(), 500u);
  EXPECT_EQ(drain(monitor, 500), (std::vector<std::string>{"reset"}));
  EXPECT_EQ(counters.retries, 1u);
}

TEST(SessionMonitor, ChangedSessionInReportMeansResetThenReplayInOrder) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  monitor.register_init(1);
  monitor.register_init(2);
  monitor.start(0);
  drain(monitor, 0);
  monitor.on_reset_event(100, 10);
  drain(monitor, 10);
  monitor.on_session_report(100, 5000);  // same session: nothing happens
  EXPECT_TRUE(drain(monitor, 5000).empty());
  monitor.on_session_report(200, 10000);  // the device restarted behind our back
  EXPECT_EQ(drain(monitor, 10000), (std::vector<std::string>{"detected", "reset"}));
  EXPECT_EQ(counters.resets, 1u);
  monitor.on_session_report(200, 10050);  // reports are ignored while waiting for the ResetEvent
  EXPECT_TRUE(drain(monitor, 10050).empty());
  monitor.on_reset_event(300, 10100);
  EXPECT_EQ(drain(monitor, 10100), (std::vector<std::string>{"init 1", "init 2", "established"}));
  EXPECT_EQ(monitor.session_id(), 300u);
  EXPECT_EQ(counters.resets, 1u);
}

TEST(SessionMonitor, UnsolicitedResetEventWithNewIdIsDetected) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  monitor.register_init(9);
  monitor.start(0);
  drain(monitor, 0);
  monitor.on_reset_event(1, 10);
  drain(monitor, 10);
  monitor.on_reset_event(1, 20);  // a repeated event of the same session is harmless
  EXPECT_TRUE(drain(monitor, 20).empty());
  monitor.on_reset_event(2, 30);
  EXPECT_EQ(drain(monitor, 30), (std::vector<std::string>{"detected", "reset"}));
  monitor.on_reset_event(3, 60);
  EXPECT_EQ(drain(monitor, 60), (std::vector<std::string>{"init 9", "established"}));
}

TEST(SessionMonitor, LostStateOfAnEstablishedSessionIsAReset) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  ASSERT_EQ(monitor.register_init(4), Status::ok);
  monitor.start(0);
  drain(monitor, 0);
  monitor.on_state_lost(10);  // before a session: nothing was set up to lose
  EXPECT_TRUE(drain(monitor, 10).empty());
  monitor.on_reset_event(21, 20);
  monitor.on_state_lost(20);  // while the inits are replayed: they are what sets it up
  EXPECT_EQ(drain(monitor, 20), (std::vector<std::string>{"init 4", "established"}));
  EXPECT_EQ(counters.resets, 0u);
  monitor.on_state_lost(30);
  EXPECT_EQ(drain(monitor, 30), (std::vector<std::string>{"detected", "reset"}));
  EXPECT_EQ(counters.resets, 1u);
  monitor.on_reset_event(22, 40);
  EXPECT_EQ(drain(monitor, 40), (std::vector<std::string>{"init 4", "established"}));
  EXPECT_EQ(monitor.session_id(), 22u);
}

TEST(SessionMonitor, WithResetAckRequiredABootAnnouncementBeforeTheAckIsNotAdopted) {
  // Regression: the device's own boot ResetEvent arrived while our Reset was on the way; adopting it made
  // the reboot our Reset caused look like an unexpected restart.
  LinkCounters counters;
  SessionTiming with_ack = timing();
  with_ack.require_reset_ack = true;
  Monitor monitor(with_ack, counters);
  monitor.register_init(4);
  monitor.start(0);
  ASSERT_EQ(drain(monitor, 0), (std::vector<std::string>{"reset"}));
  monitor.on_reset_event(111, 5);  // the boot announcement: ignored
  EXPECT_TRUE(drain(monitor, 5).empty());
  monitor.on_reset_acknowledged(8);
  monitor.on_reset_event(222, 20);  // the reboot our Reset caused
  EXPECT_EQ(drain(monitor, 20), (std::vector<std::string>{"init 4", "established"}));
  EXPECT_EQ(monitor.session_id(), 222u);
  EXPECT_EQ(counters.resets, 0u);
}

TEST(SessionMonitor, AResentResetNeedsItsOwnAck) {
  LinkCounters counters;
  SessionTiming with_ack = timing();
  with_ack.require_reset_ack = true;
  Monitor monitor(with_ack, counters);
  monitor.start(0);
  drain(monitor, 0);
  monitor.on_reset_acknowledged(1);
  ASSERT_EQ(drain(monitor, 500), (std::vector<std::string>{"reset"}));  // no ResetEvent came: again
  monitor.on_reset_event(7, 510);  // before the second Reset's ack
  EXPECT_EQ(monitor.state(), SessionState::awaiting_reset_event);
  monitor.on_reset_acknowledged(520);
  monitor.on_reset_event(8, 530);
  EXPECT_EQ(drain(monitor, 530), (std::vector<std::string>{"established"}));
}

TEST(SessionMonitor, InitCapacityIsBounded) {
  LinkCounters counters;
  SessionMonitor<uint32_t, 2> monitor(timing(), counters);
  EXPECT_EQ(monitor.register_init(1), Status::ok);
  EXPECT_EQ(monitor.register_init(2), Status::ok);
  EXPECT_EQ(monitor.register_init(3), Status::busy);
  EXPECT_EQ(monitor.init_count(), 2);
}

TEST(SessionMonitor, EventsBeforeStartAreIgnored) {
  LinkCounters counters;
  Monitor monitor(timing(), counters);
  monitor.on_reset_event(5, 0);
  monitor.on_session_report(6, 0);
  EXPECT_TRUE(drain(monitor, 0).empty());
  EXPECT_EQ(monitor.state(), SessionState::idle);
}

}  // namespace
}  // namespace tether::session
