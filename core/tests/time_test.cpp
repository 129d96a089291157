#include "tether/core/time.hpp"

#include <gtest/gtest.h>

namespace tether {
namespace {

TEST(Ticks, DifferenceAcross32BitWrap) {
  EXPECT_EQ(tick_difference<uint32_t>(5u, 0xFFFFFFFBu), 10);
  EXPECT_EQ(tick_difference<uint32_t>(0xFFFFFFFBu, 5u), -10);
  EXPECT_TRUE(tick_reached<uint32_t>(5u, 0xFFFFFFFBu));
  EXPECT_FALSE(tick_reached<uint32_t>(0xFFFFFFFBu, 5u));
}

TEST(Ticks, DifferenceAcross16BitWrap) {
  EXPECT_EQ(tick_difference<uint16_t>(3, 65533), 6);
  EXPECT_TRUE(tick_reached<uint16_t>(3, 65533));
  EXPECT_FALSE(tick_reached<uint16_t>(65533, 3));
  EXPECT_EQ(tick_earlier<uint16_t>(3, 65533), 65533);
}

TEST(Deadline, DisarmedNeverExpires) {
  const Deadline deadline;
  EXPECT_FALSE(deadline.expired(0));
  EXPECT_FALSE(deadline.expired(0x80000000u));
  EXPECT_EQ(deadline.remaining(0), 0u);
}

TEST(Deadline, ExpiresExactlyAtItsInstant) {
  Deadline deadline;
  deadline.arm(1000, 500);
  EXPECT_FALSE(deadline.expired(1499));
  EXPECT_TRUE(deadline.expired(1500));
  EXPECT_EQ(deadline.remaining(1200), 300u);
  EXPECT_EQ(deadline.remaining(1600), 0u);
}

TEST(Deadline, WorksAcrossTheWrapOfMillis) {
  Deadline deadline;
  deadline.arm(0xFFFFFF00u, 0x200);  // expires at 0x100 after the wrap
  EXPECT_FALSE(deadline.expired(0xFFFFFFFFu));
  EXPECT_FALSE(deadline.expired(0xFFu));
  EXPECT_TRUE(deadline.expired(0x100u));
  EXPECT_EQ(deadline.remaining(0xFFFFFFFFu), 0x101u);
}

}  // namespace
}  // namespace tether
