/// @file manual_clock.hpp
/// A `LinkClock` that moves only when a test says so: clients built on it (their `Options::clock`) see
/// simulated time, so a test asserts "the re-send went out after exactly 250 ms" without reading the wall
/// clock, and a loaded machine cannot make a deadline pass early or late.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "tether/client/link_clock.hpp"

namespace tether::client::testing {

/// Manual clock: `now()` changes only through `advance`/`set`. Thread-safe.
class ManualClock final : public LinkClock, public std::enable_shared_from_this<ManualClock> {
 public:
  /// A clock reading `start` (a value near the 32-bit wrap tests the wrap).
  static std::shared_ptr<ManualClock> create(Millis start = 1000);

  Millis now() const override;
  std::unique_ptr<LinkTimer> make_timer(const boost::asio::any_io_executor& executor) override;

  /// Moves the clock `by` ms forward and completes (posts) every wait whose instant was reached, in the
  /// order of their instants.
  void advance(Duration by);
  /// Moves the clock to `instant` (wrap-safe, forward only: an instant behind `now()` changes nothing).
  void advance_to(Millis instant);
  /// Waits pending on the clock's timers (a test waits for the client to arm one before advancing).
  std::size_t pending() const;
  /// The earliest pending instant, when a wait is pending (`next_due` false otherwise).
  bool next_due(Millis& at) const;
  /// Waits (wall clock, at most `timeout`) until the earliest pending instant is `at`: the client armed
  /// that deadline and none before it. False otherwise; `seen` then holds the last earliest instant (or
  /// `now()` when none was pending). A test asserts on simulated time with it: "the re-send is due exactly
  /// 200 ms after the send".
  bool wait_for_due(Millis at, Millis& seen, std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) const;
  /// `wait_for_due(at, seen, timeout)`, then advances the clock to `at`: "the re-send went out exactly at
  /// `at`" asserted and caused in one step. False (the clock unmoved) when the client armed another instant.
  bool advance_to_due(Millis at, Millis& seen, std::chrono::milliseconds timeout = std::chrono::milliseconds(10000));
  /// Waits (wall clock, at most `timeout`) until some wait is pending and advances the clock to the earliest
  /// one. False when none came.
  bool advance_to_next(std::chrono::milliseconds timeout = std::chrono::milliseconds(5000));
  /// Advances the clock deadline by deadline (to each earliest pending wait as the client arms it, at most
  /// `max_step` ms at a time when `max_step` is not 0) until `done()` holds; false when it still does not
  /// after `timeout` of wall time. A client that has not armed its next deadline yet (a write in flight)
  /// may see a later one pass first: tests where that matters cap the step and make the later deadlines
  /// unreachable.
  bool advance_until(const std::function<bool()>& done,
                     std::chrono::milliseconds timeout = std::chrono::milliseconds(10000), Duration max_step = 0);

 private:
  struct Wait;
  class Timer;
  ManualClock(Millis start) : now_(start) {}

  mutable std::mutex mutex_;
  Millis now_;
  std::vector<std::shared_ptr<Wait>> waits_;
};

}  // namespace tether::client::testing
