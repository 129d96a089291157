// WritePacer: one test per rule of core/session/write_pacer.hpp, on a fake clock.
#include "tether/core/session/write_pacer.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <deque>
#include <random>

#include "tether/testing/random_seed.hpp"

namespace tether::session {
namespace {

LinkPacing slow_receiver() {
  LinkPacing pacing;
  pacing.baud = 115200;
  pacing.receiver_buffer = 64;
  pacing.receiver_poll_interval = 20;  // a node whose loop comes round every 20 ms
  return pacing;
}

// Rule 1: a writer that sends whenever allowed never puts more than receiver_buffer bytes into any
// window of receiver_poll_interval ms, wherever the window starts.
TEST(WritePacer, NoWindowOfThePollIntervalCarriesMoreThanTheReceiverBuffer) {
  const LinkPacing pacing = slow_receiver();
  WritePacer pacer(pacing, 1000);
  std::deque<std::pair<Millis, uint16_t>> sent;  // (ms, bytes) of the last window
  uint32_t in_window = 0;
  uint32_t total = 0;
  for (Millis now = 1000; now < 6000; ++now) {
    const uint16_t bytes = pacer.allowance(now);
    pacer.consume(bytes);
    total += bytes;
    sent.emplace_back(now, bytes);
    in_window += bytes;
    while (tick_difference(now, sent.front().first) >= static_cast<int32_t>(pacing.receiver_poll_interval)) {
      in_window -= sent.front().second;
      sent.pop_front();
    }
    ASSERT_LE(in_window, pacing.receiver_buffer) << "at " << now;
  }
  // And it is not needlessly slow: about half the buffer per interval (32 bytes / 20 ms = 1.6 bytes/ms).
  EXPECT_GE(total, 5000u * 32u / 20u - 64u);
}

// Rule 2: a receiver that keeps up leaves the line rate as the only limit.
TEST(WritePacer, KeepingUpReceiverIsPacedAtTheLineRate) {
  LinkPacing pacing;
  pacing.baud = 115200;  // 11.52 bytes per ms
  pacing.receiver_buffer = 64;
  pacing.receiver_poll_interval = 0;
  WritePacer pacer(pacing, 0);
  EXPECT_EQ(pacer.rate(), 11520u);
  uint32_t total = 0;
  for (Millis now = 0; now < 1000; ++now) {
    const uint16_t bytes = pacer.allowance(now);
    pacer.consume(bytes);
    total += bytes;
  }
  // 32 bytes of initial burst + 999 ms at 11.52 bytes/ms.
  EXPECT_NEAR(static_cast<double>(total), 32.0 + 999 * 11.52, 2.0);
}

// Rule 3: the bucket starts full, and slow rates accumulate fractions instead of rounding to zero.
TEST(WritePacer, StartsFullAndAccumulatesFractionsOfBytes) {
  LinkPacing pacing;
  pacing.baud = 9600;
  pacing.receiver_buffer = 8;
  pacing.receiver_poll_interval = 1000;  // 4 bytes per second: 0.004 bytes per ms
  WritePacer pacer(pacing, 0);
  EXPECT_EQ(pacer.allowance(0), 4u);
  pacer.consume(4);
  EXPECT_EQ(pacer.allowance(0), 0u);
  uint32_t total = 0;
  for (Millis now = 1; now <= 1000; ++now) {
    const uint16_t bytes = pacer.allowance(now);
    pacer.consume(bytes);
    total += bytes;
  }
  EXPECT_EQ(total, 4u);
}

// Rule 4: never more than the depth, and next_allowed is exact.
TEST(WritePacer, AllowanceIsCappedAndNextAllowedIsWhenTheBytesAreThere) {
  const LinkPacing pacing = slow_receiver();  // depth 32 bytes, 1.6 bytes per ms
  WritePacer pacer(pacing, 0);
  EXPECT_EQ(pacer.depth(), 32u);
  EXPECT_EQ(pacer.allowance(100000), 32u);  // a long idle gap does not overfill (nor overflow)
  pacer.consume(32);
  const Millis at = pacer.next_allowed(16, 100000);
  EXPECT_EQ(at, 100010u);  // 16 bytes at 1.6 bytes/ms
  EXPECT_EQ(pacer.allowance(at - 1), 14u);
  EXPECT_EQ(pacer.allowance(at), 16u);
  EXPECT_EQ(pacer.next_allowed(1000, at), at + 10u);  // more than the depth means the depth
}

TEST(WritePacer, WorksAcrossTheClockWrap) {
  const LinkPacing pacing = slow_receiver();
  const Millis start = 0xFFFFFFF0u;
  WritePacer pacer(pacing, start);
  pacer.consume(pacer.allowance(start));
  EXPECT_EQ(pacer.allowance(start + 20u), 32u);  // 20 ms later, across the wrap
}

TEST(WritePacer, RandomWritersNeverOverrunTheReceiver) {
  const uint64_t seed = testing::random_seed();
  std::mt19937_64 random(seed);
  for (int round = 0; round < 50; ++round) {
    LinkPacing pacing;
    pacing.baud = 9600u * (1u + static_cast<uint32_t>(random() % 12));
    pacing.receiver_buffer = static_cast<uint16_t>(16 + random() % 240);
    pacing.receiver_poll_interval = static_cast<uint16_t>(random() % 50);
    const uint32_t window = pacing.receiver_poll_interval == 0 ? 1u : pacing.receiver_poll_interval;
    Millis now = static_cast<Millis>(random());
    WritePacer pacer(pacing, now);
    std::deque<std::pair<Millis, uint16_t>> sent;
    uint32_t in_window = 0;
    for (int step = 0; step < 2000; ++step) {
      now += static_cast<Millis>(random() % 4);
      const uint16_t allowed = pacer.allowance(now);
      const uint16_t bytes = static_cast<uint16_t>(allowed == 0 ? 0 : random() % (allowed + 1u));
      pacer.consume(bytes);
      sent.emplace_back(now, bytes);
      in_window += bytes;
      while (static_cast<uint32_t>(tick_difference(now, sent.front().first)) >= window) {
        in_window -= sent.front().second;
        sent.pop_front();
      }
      if (pacing.receiver_poll_interval != 0) {
        ASSERT_LE(in_window, pacing.receiver_buffer) << "seed " << seed << " round " << round;
      }
    }
  }
}

// Rule 5: take(wanted) is allowance + consume of min(wanted, allowance), step for step.
TEST(WritePacer, TakeIsAllowanceAndConsumeInOneStep) {
  const uint64_t seed = testing::random_seed();
  std::mt19937_64 random(seed);
  for (int round = 0; round < 50; ++round) {
    LinkPacing pacing;
    pacing.baud = 300u + static_cast<uint32_t>(random() % 250000);
    pacing.receiver_buffer = static_cast<uint16_t>(1 + random() % 512);
    pacing.receiver_poll_interval = static_cast<uint16_t>(random() % 100);
    Millis now = static_cast<Millis>(random());
    WritePacer taking(pacing, now);
    WritePacer reference(pacing, now);
    ASSERT_EQ(taking.depth(), reference.allowance(now)) << "seed " << seed << ": a new bucket is full";
    for (int step = 0; step < 500; ++step) {
      now += static_cast<Millis>(random() % 6);
      const uint16_t wanted = static_cast<uint16_t>(random() % (2u * taking.depth() + 2u));
      const uint16_t allowed = reference.allowance(now);
      const uint16_t expected = wanted < allowed ? wanted : allowed;
      reference.consume(expected);
      ASSERT_EQ(taking.take(wanted, now), expected) << "seed " << seed << " round " << round << " step " << step;
      ASSERT_EQ(taking.allowance(now), reference.allowance(now)) << "seed " << seed << " round " << round;
      ASSERT_EQ(taking.next_allowed(taking.depth(), now), reference.next_allowed(reference.depth(), now));
    }
  }
}

}  // namespace
}  // namespace tether::session
