// The boot detection state machine on a fake clock: time points are built from plain milliseconds.
#include "tether/transports/boot_detection.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using namespace std::string_view_literals;
using Action = BootDetector::Step::Action;

BootDetector::TimePoint at(std::chrono::milliseconds ms) { return BootDetector::TimePoint{} + ms; }

// An announcement "HELLO" anywhere in what arrived; what follows it is the client's.
BootSignature announcing() {
  BootSignature signature;
  signature.name = "HELLO";
  signature.find_announcement = [](std::string_view received) -> std::optional<std::size_t> {
    const auto offset = received.find("HELLO");
    if (offset == std::string_view::npos) return std::nullopt;
    return offset;
  };
  return signature;
}

// A probe "?" answered by a line "ok\r\n".
BootSignature probing() {
  BootSignature signature;
  signature.name = "probe ?";
  signature.probe = "?";
  signature.probe_answered = [](std::string_view received) { return received.find("ok\r\n") != std::string_view::npos; };
  signature.silence = 1000ms;
  signature.probe_interval = 100ms;
  return signature;
}

TEST(BootDetector, ModesAndOutcomesHaveNames) {
  EXPECT_EQ(parse_boot_mode("detect"), BootMode::detect);
  EXPECT_EQ(parse_boot_mode("fixed"), BootMode::fixed);
  EXPECT_EQ(parse_boot_mode("none"), BootMode::none);
  EXPECT_FALSE(parse_boot_mode("Detect"));
  EXPECT_STREQ(to_string(BootOutcome::upper_bound), "upper bound");
  EXPECT_FALSE(BootSignature{}.usable());
  BootSignature probe_without_answer;
  probe_without_answer.probe = "?";
  EXPECT_FALSE(probe_without_answer.usable());
  EXPECT_TRUE(announcing().usable());
  EXPECT_TRUE(probing().usable());
}

TEST(BootDetector, AnnouncementEndsTheWaitAndKeepsItAndWhatFollowsForTheClient) {
  BootDetector detector(announcing(), 2000ms, at(0ms));
  const auto first = detector.start();
  EXPECT_EQ(first.action, Action::wait);
  EXPECT_EQ(first.wake, at(2000ms));  // nothing to probe: only the upper bound
  EXPECT_EQ(detector.on_bytes("\xff\x00noiseHEL"sv, at(400ms)).action, Action::wait);  // split across reads
  const auto ready = detector.on_bytes("LOrest", at(1080ms));
  EXPECT_EQ(ready.action, Action::ready);
  EXPECT_EQ(detector.kept(), "HELLOrest");
  EXPECT_EQ(detector.report().outcome, BootOutcome::announced);
  EXPECT_EQ(detector.report().mode, BootMode::detect);
  EXPECT_EQ(detector.report().ready_after, 1080ms);
  EXPECT_EQ(detector.report().probes, 0u);
}

TEST(BootDetector, SilentBoardIsProbedAfterTheQuietWindowThenEveryIntervalUntilItAnswers) {
  BootDetector detector(probing(), 2000ms, at(0ms));
  EXPECT_EQ(detector.start().wake, at(1000ms));
  EXPECT_EQ(detector.on_timer(at(999ms)).action, Action::wait);  // early wake-up: nothing yet
  const auto probe = detector.on_timer(at(1000ms));
  EXPECT_EQ(probe.action, Action::probe);
  EXPECT_EQ(probe.wake, at(1100ms));
  // The first probe went into the bootloader and was lost: the next one comes an interval later.
  const auto again = detector.on_timer(at(1100ms));
  EXPECT_EQ(again.action, Action::probe);
  EXPECT_EQ(detector.on_bytes("o", at(1130ms)).action, Action::wait);
  EXPECT_EQ(detector.on_bytes("k\r\n", at(1131ms)).action, Action::ready);
  EXPECT_EQ(detector.kept(), "");  // the probe's answer is not the client's
  EXPECT_EQ(detector.report().outcome, BootOutcome::probed);
  EXPECT_EQ(detector.report().ready_after, 1131ms);
  EXPECT_EQ(detector.report().probes, 2u);
}

TEST(BootDetector, BootNoiseRestartsTheQuietWindowBeforeTheFirstProbe) {
  BootDetector detector(probing(), 5000ms, at(0ms));
  (void)detector.start();
  const auto after_noise = detector.on_bytes("\xf0\x10", at(600ms));
  EXPECT_EQ(after_noise.action, Action::wait);
  EXPECT_EQ(after_noise.wake, at(1600ms));
  EXPECT_EQ(detector.on_timer(at(1000ms)).action, Action::wait);
  EXPECT_EQ(detector.on_timer(at(1600ms)).action, Action::probe);
}

TEST(BootDetector, BytesBeforeTheProbeAreNoAnswer) {
  BootDetector detector(probing(), 5000ms, at(0ms));
  (void)detector.start();
  EXPECT_EQ(detector.on_bytes("ok\r\n", at(10ms)).action, Action::wait);  // not asked yet: noise
  EXPECT_EQ(detector.on_timer(at(1010ms)).action, Action::probe);
  EXPECT_EQ(detector.on_bytes("ok\r\n", at(1020ms)).action, Action::ready);
}

TEST(BootDetector, BoardThatNeverAnnouncesEndsAtTheUpperBoundNeverLater) {
  BootDetector detector(probing(), 1500ms, at(0ms));
  (void)detector.start();
  BootDetector::Step step = detector.on_timer(at(1000ms));
  EXPECT_EQ(step.action, Action::probe);
  // Follow the wake times as a timer would: probes every 100 ms, never a wake past the bound.
  while (step.action == Action::wait || step.action == Action::probe) {
    EXPECT_LE(step.wake, at(1500ms));
    step = detector.on_timer(step.wake);
  }
  EXPECT_EQ(step.action, Action::gave_up);
  EXPECT_EQ(detector.report().outcome, BootOutcome::upper_bound);
  EXPECT_EQ(detector.report().ready_after, 1500ms);
  EXPECT_EQ(detector.report().probes, 5u);  // 1000, 1100, 1200, 1300, 1400
  EXPECT_TRUE(detector.kept().empty());
}

TEST(BootDetector, UpperBoundBelowTheQuietWindowNeverProbes) {
  BootDetector detector(probing(), 500ms, at(0ms));
  EXPECT_EQ(detector.start().wake, at(500ms));
  EXPECT_EQ(detector.on_timer(at(500ms)).action, Action::gave_up);
  EXPECT_EQ(detector.report().probes, 0u);
}

TEST(BootDetector, EndlessNoiseIsBoundedAndAnAnnouncementInItStillCounts) {
  BootDetector detector(announcing(), 2000ms, at(0ms));
  (void)detector.start();
  const std::string noise(300, 'x');
  for (int i = 0; i < 20; ++i) EXPECT_EQ(detector.on_bytes(noise, at(std::chrono::milliseconds(i))).action, Action::wait);
  EXPECT_EQ(detector.on_bytes("HELLO", at(50ms)).action, Action::ready);
  EXPECT_EQ(detector.kept(), "HELLO");
}

}  // namespace
}  // namespace tether::transports
