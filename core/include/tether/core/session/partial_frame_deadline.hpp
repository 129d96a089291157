/// @file partial_frame_deadline.hpp
/// Device half: a frame must be complete within a deadline after its first byte, or it is dropped.
///
/// Protects a receiver from waiting forever on half a frame (bytes lost on the line, a sender that
/// stalled). Romi: 1 s from '#' to '\n', answered with the controller-timeout error; Elcano: partial
/// messages older than a deadline are dropped. The decoder reports frame start and end; `poll` tells when
/// the frame in progress has expired so the codec resets its decoder and reports it.
#pragma once

#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// Deadline of the frame being received.
class PartialFrameDeadline {
 public:
  /// Frames must complete within `limit` ms; `counters` (outliving it) receives partial_timeouts.
  constexpr PartialFrameDeadline(Duration limit, LinkCounters& counters) : limit_(limit), counters_(&counters) {}

  /// A frame started at `now` (a new start byte restarts the window).
  void on_frame_start(Millis now) { deadline_.arm(now, limit_); }
  /// The frame ended (complete or rejected); no deadline until the next start.
  void on_frame_end() { deadline_.disarm(); }
  /// True exactly once when the frame in progress reaches its deadline; the caller drops the frame.
  bool poll(Millis now) {
    if (!deadline_.expired(now)) return false;
    deadline_.disarm();
    ++counters_->partial_timeouts;
    return true;
  }
  /// True while a frame is in progress.
  bool in_frame() const { return deadline_.armed(); }
  /// The deadline of the frame in progress (disarmed when none).
  Deadline deadline() const { return deadline_; }

 private:
  Duration limit_;
  LinkCounters* counters_;
  Deadline deadline_;
};

}  // namespace session
}  // namespace tether
