// The message-id sequence and the window check shared by the clients whose devices keep a duplicate filter.
#include "tether/client/message_ids.hpp"

#include <gtest/gtest.h>

#include <set>
#include <vector>

namespace {

using tether::client::MessageIds;

TEST(MessageIds, IdsSkipZeroAndWhatIsInFlightAndWrap) {
  std::set<std::uint32_t> in_flight{0xFFFFFFFFu};
  const auto taken = [&](std::uint32_t id) { return in_flight.count(id) != 0; };
  MessageIds ids(0xFFFFFFFEu, 8);
  EXPECT_EQ(ids.peek(taken), 0xFFFFFFFEu);
  EXPECT_EQ(ids.next(taken), 0xFFFFFFFEu);
  EXPECT_EQ(ids.next(taken), 1u);  // 0xFFFFFFFF in flight, 0 never
  EXPECT_EQ(ids.last(), 1u);
  EXPECT_EQ(MessageIds(0, 8).next(taken), 1u);
}

TEST(MessageIds, AnAnchorIsTheOldestIdInFlightOrTheIdItself) {
  const auto none = [](std::uint32_t) { return false; };
  MessageIds ids(0xFFFFFFFDu, 8);
  const std::uint32_t a = ids.next(none);
  EXPECT_EQ(ids.anchor(a, std::vector<std::uint32_t>{}), a);
  const std::uint32_t b = ids.next(none);
  const std::uint32_t c = ids.next(none);  // across the wrap: a is still the oldest
  EXPECT_EQ(ids.anchor(c, std::vector<std::uint32_t>{b, a}), a);
  EXPECT_EQ(ids.anchor(c, std::vector<std::uint32_t>{b}), b);
}

TEST(MessageIds, TheWindowHoldsEveryUnackedMessagesAnchor) {
  std::set<std::uint32_t> in_flight;
  const auto taken = [&](std::uint32_t id) { return in_flight.count(id) != 0; };
  MessageIds ids(100, 4);
  EXPECT_TRUE(ids.window_open(std::vector<std::uint32_t>{}, taken));
  const std::uint32_t first = ids.next(taken);  // 100, its own anchor
  in_flight.insert(first);
  // 101, 102, 103 stay within 4 ids of anchor 100; the next (104) would not.
  for (std::uint32_t expected = 101; expected <= 103; ++expected) {
    ASSERT_TRUE(ids.window_open(std::vector<std::uint32_t>{first}, taken)) << expected;
    EXPECT_EQ(ids.next(taken), expected);
  }
  EXPECT_FALSE(ids.window_open(std::vector<std::uint32_t>{first}, taken));
  // 100 acked: only what is still unacked counts (here an anchor of 102).
  EXPECT_TRUE(ids.window_open(std::vector<std::uint32_t>{102}, taken));
  EXPECT_FALSE(ids.window_open(std::vector<std::uint32_t>{100, 102}, taken));
}

}  // namespace
