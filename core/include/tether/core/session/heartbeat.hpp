/// @file heartbeat.hpp
/// Host half of liveness: when to send the next heartbeat (the proxy protocol's 1 s ping).
///
/// Fixed-rate schedule: beats are due at start, start + period, start + 2 period, ... so a slow write does
/// not make the period drift. If the client falls behind by more than a whole period (a stalled link),
/// the schedule restarts from the late beat instead of firing a burst of catch-up pings.
#pragma once

#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// Periodic heartbeat timer, sans-I/O.
class HeartbeatSchedule {
 public:
  /// Schedule with `period` ms between beats; stopped until `start`.
  explicit HeartbeatSchedule(Duration period) : period_(period) {}

  /// Starts beating: the first beat is due at `now`.
  void start(Millis now) { next_.arm_at(now); }
  /// Stops; `due` is false until `start` is called again.
  void stop() { next_.disarm(); }
  /// True when a beat should be sent at `now`.
  bool due(Millis now) const { return next_.expired(now); }
  /// Records that the due beat was sent at `now` and schedules the next one.
  void beat_sent(Millis now) {
    if (!next_.armed()) return;
    const Millis following = static_cast<Millis>(next_.at() + period_);
    next_.arm_at(tick_reached(now, following) ? static_cast<Millis>(now + period_) : following);
  }
  /// When the next beat is due (disarmed when stopped): the client's timer target.
  Deadline next() const { return next_; }
  /// The period in ms.
  Duration period() const { return period_; }

 private:
  Duration period_;
  Deadline next_;
};

}  // namespace session
}  // namespace tether
