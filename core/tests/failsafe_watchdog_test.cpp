#include "tether/core/session/failsafe_watchdog.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace tether::session {
namespace {

struct Recorder {
  std::vector<Millis> fired_at;
  static void on_failsafe(void* context, Millis now) { static_cast<Recorder*>(context)->fired_at.push_back(now); }
};

// Polls every millisecond from `from` to `to` inclusive.
void run(FailsafeWatchdog& watchdog, Millis from, Millis to) {
  for (Millis now = from; now <= to; ++now) watchdog.poll(now);
}

TEST(FailsafeWatchdog, FiresAtExactlyTheConfiguredSilence) {
  LinkCounters counters;
  Recorder recorder;
  FailsafeWatchdog watchdog(10000, counters, &Recorder::on_failsafe, &recorder);
  watchdog.start(0);
  run(watchdog, 0, 9999);
  EXPECT_TRUE(recorder.fired_at.empty());
  run(watchdog, 10000, 10000);
  EXPECT_EQ(recorder.fired_at, (std::vector<Millis>{10000}));
  EXPECT_TRUE(watchdog.triggered());
  EXPECT_TRUE(watchdog.in_failsafe());
  EXPECT_EQ(counters.failsafes, 1u);
}

TEST(FailsafeWatchdog, HeartbeatsKeepItQuiet) {
  LinkCounters counters;
  Recorder recorder;
  FailsafeWatchdog watchdog(10000, counters, &Recorder::on_failsafe, &recorder);
  watchdog.start(0);
  for (Millis now = 0; now <= 60000; ++now) {
    if (now % 1000 == 0) watchdog.on_heartbeat(now);
    watchdog.poll(now);
  }
  EXPECT_TRUE(recorder.fired_at.empty());
  EXPECT_FALSE(watchdog.triggered());
}

TEST(FailsafeWatchdog, SilenceIsMeasuredFromTheLastHeartbeat) {
  LinkCounters counters;
  Recorder recorder;
  FailsafeWatchdog watchdog(10000, counters, &Recorder::on_failsafe, &recorder);
  watchdog.start(0);
  watchdog.on_heartbeat(3456);
  run(watchdog, 0, 13455);
  EXPECT_TRUE(recorder.fired_at.empty());
  run(watchdog, 13456, 13456);
  EXPECT_EQ(recorder.fired_at, (std::vector<Millis>{13456}));
}

TEST(FailsafeWatchdog, FiresOncePerSilenceAndAgainAfterANewSilence) {
  LinkCounters counters;
  Recorder recorder;
  FailsafeWatchdog watchdog(10000, counters, &Recorder::on_failsafe, &recorder);
  watchdog.start(0);
  run(watchdog, 0, 30000);
  EXPECT_EQ(recorder.fired_at.size(), 1u);
  watchdog.on_heartbeat(30000);
  EXPECT_FALSE(watchdog.in_failsafe());
  EXPECT_TRUE(watchdog.triggered());  // sticky until cleared
  run(watchdog, 30001, 40000);
  EXPECT_EQ(recorder.fired_at, (std::vector<Millis>{10000, 40000}));
  EXPECT_EQ(counters.failsafes, 2u);
}

TEST(FailsafeWatchdog, ClearTriggeredResetsOnlyTheFlag) {
  LinkCounters counters;
  FailsafeWatchdog watchdog(100, counters);
  watchdog.start(0);
  EXPECT_TRUE(watchdog.poll(100));  // no callback: the return value tells
  watchdog.clear_triggered();
  EXPECT_FALSE(watchdog.triggered());
  EXPECT_TRUE(watchdog.in_failsafe());
  EXPECT_FALSE(watchdog.poll(500));
}

TEST(FailsafeWatchdog, NotStartedNeverFires) {
  LinkCounters counters;
  FailsafeWatchdog watchdog(100, counters);
  EXPECT_FALSE(watchdog.poll(1000000));
}

TEST(FailsafeWatchdog, WorksAcrossTheClockWrap) {
  LinkCounters counters;
  FailsafeWatchdog watchdog(10000, counters);
  watchdog.start(0xFFFFF000u);
  EXPECT_FALSE(watchdog.poll(0x170Fu));
  EXPECT_TRUE(watchdog.poll(0x1710u));  // 0xFFFFF000 + 10000 wraps to 0x1710
}

}  // namespace
}  // namespace tether::session
