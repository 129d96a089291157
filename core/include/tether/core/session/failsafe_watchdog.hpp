/// @file failsafe_watchdog.hpp
/// Device half of liveness: enter the failsafe after a silence of the host's heartbeat.
///
/// The proxy protocol's rule: without a ping for 10 s, every initialised output goes to its safe value and
/// the sticky `pingFailsafeTriggered` flag is set until the host clears it (PingFailsafeReset). The
/// watchdog measures silence from `start` (boot) or the last heartbeat and calls the application's
/// failsafe handler.
///
/// Contract of the failsafe callback:
///   1. It is called only from `poll`, in the caller's context (never from an interrupt).
///   2. It is called when `now - last heartbeat >= silence_limit`, i.e. at the first poll at or after the
///      limit: exactly at the limit when polled every millisecond.
///   3. It is called at most once per silence: again only after a heartbeat and a new full silence.
///   4. It must not call `poll` of the same watchdog; it may call `triggered` and `clear_triggered`.
#pragma once

#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// Heartbeat silence detector with a sticky flag.
class FailsafeWatchdog {
 public:
  /// Failsafe handler: `context` as given to the constructor, `now` of the poll that fired.
  using Callback = void (*)(void* context, Millis now);

  /// Watchdog firing after `silence_limit` ms; `callback` may be null (poll's return value then tells);
  /// `counters` (outliving it) receives failsafes.
  constexpr FailsafeWatchdog(Duration silence_limit, LinkCounters& counters, Callback callback = nullptr,
                   void* context = nullptr)
      : limit_(silence_limit), counters_(&counters), callback_(callback), context_(context) {}

  /// Starts measuring silence at `now` (boot).
  void start(Millis now) {
    deadline_.arm(now, limit_);
    in_failsafe_ = false;
  }
  /// A heartbeat arrived: silence ends, a new one is measured from `now`.
  void on_heartbeat(Millis now) {
    deadline_.arm(now, limit_);
    in_failsafe_ = false;
  }
  /// Fires the failsafe when the silence reached the limit; true when it fired in this call.
  bool poll(Millis now) {
    if (in_failsafe_ || !deadline_.expired(now)) return false;
    in_failsafe_ = true;
    triggered_ = true;
    ++counters_->failsafes;
    if (callback_ != nullptr) callback_(context_, now);
    return true;
  }
  /// Sticky flag: a failsafe happened since the last `clear_triggered`.
  bool triggered() const { return triggered_; }
  /// Clears the sticky flag (PingFailsafeReset). Does not end a silence in progress.
  void clear_triggered() { triggered_ = false; }
  /// True between a failsafe and the next heartbeat.
  bool in_failsafe() const { return in_failsafe_; }
  /// When the failsafe fires if no heartbeat comes (disarmed before `start`).
  Deadline deadline() const { return deadline_; }

 private:
  Duration limit_;
  LinkCounters* counters_;
  Callback callback_;
  void* context_;
  Deadline deadline_;
  bool in_failsafe_ = false;
  bool triggered_ = false;
};

}  // namespace session
}  // namespace tether
