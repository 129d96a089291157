#include "tether/core/bytes.hpp"

#include <gtest/gtest.h>

#include "tether/core/status.hpp"

namespace tether {
namespace {

TEST(ByteView, FromLiteralExcludesTerminator) {
  const ByteView view = ByteView::from_literal("#a:00");
  EXPECT_EQ(view.size(), 5u);
  EXPECT_EQ(view[0], '#');
}

TEST(ByteView, SubviewIsClampedToTheView) {
  const ByteView view = ByteView::from_literal("abcdef");
  EXPECT_TRUE(view.subview(2, 3).equals(ByteView::from_literal("cde")));
  EXPECT_TRUE(view.subview(4).equals(ByteView::from_literal("ef")));
  EXPECT_TRUE(view.subview(4, 100).equals(ByteView::from_literal("ef")));
  EXPECT_TRUE(view.subview(6).empty());
  EXPECT_TRUE(view.subview(99, 1).empty());
}

TEST(ByteView, EqualityComparesContentAndLength) {
  EXPECT_TRUE(ByteView::from_literal("ab").equals(ByteView::from_literal("ab")));
  EXPECT_FALSE(ByteView::from_literal("ab").equals(ByteView::from_literal("abc")));
  EXPECT_FALSE(ByteView::from_literal("ab").equals(ByteView::from_literal("ac")));
}

TEST(MutableByteView, FirstIsClamped) {
  uint8_t buffer[4] = {1, 2, 3, 4};
  const MutableByteView view(buffer);
  EXPECT_EQ(view.first(2).size(), 2u);
  EXPECT_EQ(view.first(10).size(), 4u);
}

TEST(Result, CarriesValueOrStatus) {
  const Result<int> good(7);
  EXPECT_TRUE(good.ok());
  EXPECT_EQ(good.value(), 7);
  const Result<int> bad(Status::busy);
  EXPECT_FALSE(bad.ok());
  EXPECT_EQ(bad.status(), Status::busy);
}

TEST(Status, EveryValueHasAMessage) {
  for (int i = 0; i <= static_cast<int>(Status::remote_error); ++i) {
    EXPECT_STRNE(to_string(static_cast<Status>(i)), "unknown status") << i;
  }
}

}  // namespace
}  // namespace tether
