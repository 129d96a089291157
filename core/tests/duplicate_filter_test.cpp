#include "tether/core/session/duplicate_filter.hpp"

#include <gtest/gtest.h>

namespace tether::session {
namespace {

TEST(DuplicateFilter, FreshFilterKnowsNoIdNotEvenTheLast) {
  // Regression guard for the reference firmware's defect B6: it starts with "last id" 255 and rejects
  // the first request with id 255 as a duplicate.
  LinkCounters counters;
  DuplicateFilter<uint8_t, 1, 64> filter(counters);
  EXPECT_FALSE(filter.check(255, 0x1234).duplicate);
  EXPECT_FALSE(filter.check(0, 0).duplicate);
  EXPECT_EQ(counters.duplicates, 0u);
}

TEST(DuplicateFilter, RepeatedRequestGetsTheCachedReply) {
  LinkCounters counters;
  DuplicateFilter<uint8_t, 1, 64> filter(counters);
  const ByteView reply = ByteView::from_literal("#a[0]:07xx\r\n");
  ASSERT_EQ(filter.remember(7, 0xBEEF, reply), Status::ok);
  const auto lookup = filter.check(7, 0xBEEF);
  EXPECT_TRUE(lookup.duplicate);
  EXPECT_TRUE(lookup.cached_reply.equals(reply));
  EXPECT_EQ(counters.duplicates, 1u);
}

TEST(DuplicateFilter, SameIdWithOtherContentIsANewRequest) {
  LinkCounters counters;
  DuplicateFilter<uint8_t, 1, 64> filter(counters);
  filter.remember(0, 0x1111, ByteView::from_literal("x"));
  EXPECT_FALSE(filter.check(0, 0x2222).duplicate);  // e.g. a restarted host reusing id 0 for another command
}

TEST(DuplicateFilter, DepthOneForgetsThePreviousRequest) {
  LinkCounters counters;
  DuplicateFilter<uint8_t, 1, 64> filter(counters);
  filter.remember(1, 1, ByteView::from_literal("one"));
  filter.remember(2, 2, ByteView::from_literal("two"));
  EXPECT_FALSE(filter.check(1, 1).duplicate);
  EXPECT_TRUE(filter.check(2, 2).duplicate);
}

TEST(DuplicateFilter, DeeperMemoryCatchesOutOfOrderResends) {
  // The proxy host may have several messages in flight; a lost ack makes it re-send an older one after
  // newer ones were executed.
  LinkCounters counters;
  DuplicateFilter<uint32_t, 4, 0> filter(counters);
  for (uint32_t id = 10; id < 14; ++id) filter.remember(id, 0, ByteView());
  EXPECT_TRUE(filter.check(10, 0).duplicate);
  EXPECT_TRUE(filter.check(13, 0).duplicate);
  filter.remember(14, 0, ByteView());  // evicts the oldest (10)
  EXPECT_FALSE(filter.check(10, 0).duplicate);
  EXPECT_TRUE(filter.check(11, 0).duplicate);
  EXPECT_TRUE(filter.check(14, 0).cached_reply.empty());
}

TEST(DuplicateFilter, OversizeReplyIsReportedAndNotCached) {
  LinkCounters counters;
  DuplicateFilter<uint8_t, 1, 4> filter(counters);
  EXPECT_EQ(filter.remember(3, 3, ByteView::from_literal("too long")), Status::buffer_too_small);
  const auto lookup = filter.check(3, 3);
  EXPECT_TRUE(lookup.duplicate);  // still not executed twice
  EXPECT_TRUE(lookup.cached_reply.empty());
}

TEST(DuplicateFilter, ClearForgetsAll) {
  LinkCounters counters;
  DuplicateFilter<uint8_t, 2, 8> filter(counters);
  filter.remember(1, 1, ByteView());
  filter.clear();
  EXPECT_FALSE(filter.check(1, 1).duplicate);
  EXPECT_EQ(filter.size(), 0);
}

}  // namespace
}  // namespace tether::session
