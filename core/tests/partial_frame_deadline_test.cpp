#include "tether/core/session/partial_frame_deadline.hpp"

#include <gtest/gtest.h>

namespace tether::session {
namespace {

TEST(PartialFrameDeadline, IncompleteFrameExpiresOnceAtItsDeadline) {
  LinkCounters counters;
  PartialFrameDeadline deadline(1000, counters);
  deadline.on_frame_start(200);
  EXPECT_TRUE(deadline.in_frame());
  EXPECT_FALSE(deadline.poll(1199));
  EXPECT_TRUE(deadline.poll(1200));
  EXPECT_FALSE(deadline.poll(1201));  // reported once
  EXPECT_FALSE(deadline.in_frame());
  EXPECT_EQ(counters.partial_timeouts, 1u);
}

TEST(PartialFrameDeadline, CompletedFrameNeverExpires) {
  LinkCounters counters;
  PartialFrameDeadline deadline(1000, counters);
  deadline.on_frame_start(0);
  deadline.on_frame_end();
  EXPECT_FALSE(deadline.poll(5000));
  EXPECT_EQ(counters.partial_timeouts, 0u);
}

TEST(PartialFrameDeadline, NewStartRestartsTheWindow) {
  LinkCounters counters;
  PartialFrameDeadline deadline(1000, counters);
  deadline.on_frame_start(0);
  deadline.on_frame_start(800);  // a new start byte: the half frame before it is abandoned
  EXPECT_FALSE(deadline.poll(1000));
  EXPECT_TRUE(deadline.poll(1800));
}

TEST(PartialFrameDeadline, WorksAcrossTheClockWrap) {
  LinkCounters counters;
  PartialFrameDeadline deadline(1000, counters);
  deadline.on_frame_start(0xFFFFFF00u);
  EXPECT_FALSE(deadline.poll(0x2E7u));
  EXPECT_TRUE(deadline.poll(0x2E8u));
}

}  // namespace
}  // namespace tether::session
