#include "tether/core/session/heartbeat.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace tether::session {
namespace {

// Drives the schedule as a client would: poll every `step` ms, send when due, record the times.
std::vector<Millis> beats_between(HeartbeatSchedule& schedule, Millis from, Millis to, Millis step) {
  std::vector<Millis> sent;
  for (Millis now = from; now <= to; now += step) {
    if (schedule.due(now)) {
      sent.push_back(now);
      schedule.beat_sent(now);
    }
  }
  return sent;
}

TEST(HeartbeatSchedule, StoppedUntilStarted) {
  HeartbeatSchedule schedule(1000);
  EXPECT_FALSE(schedule.due(0));
  EXPECT_FALSE(schedule.due(100000));
}

TEST(HeartbeatSchedule, FirstBeatAtStartThenEveryPeriod) {
  HeartbeatSchedule schedule(1000);
  schedule.start(500);
  EXPECT_EQ(beats_between(schedule, 500, 5500, 1), (std::vector<Millis>{500, 1500, 2500, 3500, 4500, 5500}));
}

TEST(HeartbeatSchedule, CoarsePollingDoesNotDrift) {
  HeartbeatSchedule schedule(1000);
  schedule.start(0);
  // Polled every 300 ms: each beat goes out at the first poll after it is due, but the schedule stays
  // on the 1000 ms grid instead of drifting by the polling delay.
  EXPECT_EQ(beats_between(schedule, 0, 4000, 300), (std::vector<Millis>{0, 1200, 2100, 3000}));
}

TEST(HeartbeatSchedule, StallLongerThanAPeriodRestartsInsteadOfBursting) {
  HeartbeatSchedule schedule(1000);
  schedule.start(0);
  schedule.beat_sent(0);
  ASSERT_TRUE(schedule.due(3500));  // the client was stalled for 3.5 s
  schedule.beat_sent(3500);
  EXPECT_FALSE(schedule.due(4499));  // one beat, then the next a full period later
  EXPECT_TRUE(schedule.due(4500));
}

TEST(HeartbeatSchedule, NextTellsTheTimerTarget) {
  HeartbeatSchedule schedule(1000);
  schedule.start(0);
  schedule.beat_sent(0);
  EXPECT_EQ(schedule.next().at(), 1000u);
  schedule.stop();
  EXPECT_FALSE(schedule.next().armed());
}

}  // namespace
}  // namespace tether::session
