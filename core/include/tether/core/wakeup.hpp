/// @file wakeup.hpp
/// The one instant a host client's timer is armed at: the earliest of the deadlines of its parts (session
/// engine, heartbeat, queues, receivers). Portable, like `Deadline`.
#pragma once

#include "tether/core/time.hpp"

namespace tether {

/// Moves `wake` to `candidate` when that is armed and earlier than `wake` (or `wake` is disarmed): fold
/// every part's deadline into `wake`, then arm the timer at it. A disarmed candidate never wins.
inline void consider(Deadline& wake, const Deadline& candidate) {
  if (!candidate.armed()) return;
  if (!wake.armed() || tick_difference(candidate.at(), wake.at()) < 0) wake.arm_at(candidate.at());
}

/// `candidate` as an armed deadline at `at` (a queue's own instant), for `consider`.
inline Deadline deadline_at(Millis at) {
  Deadline deadline;
  deadline.arm_at(at);
  return deadline;
}

}  // namespace tether
