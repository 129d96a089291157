/// @file session_monitor.hpp
/// Host half of session tracking: detects a device reset by its session id and replays the inits.
///
/// A device announces a session id that is new at every boot (`ResetEvent` at the end of its setup,
/// periodic `ArduinoInfo` reports in the proxy protocol). The host keeps the id of the session it
/// initialised. States:
/// @code
///   idle --start()--> awaiting_reset_event --on_reset_event(id)--> replaying --poll()...--> established
///                           ^   | reset_timeout: send Reset again                                 |
///                           +---+------------ id differs from the stored one (reset detected) <----+
/// @endcode
/// The monitor never sends anything itself: `poll(now)` returns the next action (send a Reset, replay
/// init number k, tell the application) until it returns `none`. Inits are opaque keys registered by the
/// client (which keeps the encoded messages); they are replayed in registration order.
#pragma once

#include <stdint.h>

#include "tether/core/counters.hpp"
#include "tether/core/status.hpp"
#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// Where the session handshake stands.
enum class SessionState : uint8_t {
  idle,                  ///< Not started.
  awaiting_reset_event,  ///< Reset sent; waiting for the device to announce its new session.
  replaying,             ///< New session known; inits being handed out for re-sending.
  established,           ///< Device initialised in the stored session.
};

/// Timing and rules of the reset handshake.
struct SessionTiming {
  Duration reset_timeout = 3000;  ///< Re-send Reset when no ResetEvent arrives in this time.
  /// Adopt a ResetEvent only after the device acknowledged our Reset (`on_reset_acknowledged`). A device
  /// that boots by itself announces a session while our Reset is still on the way; adopting that one
  /// would make our Reset's reboot look like an unexpected restart. For protocols whose device acks the
  /// Reset before restarting (the proxy protocol).
  bool require_reset_ack = false;
};

/// Session tracker for one device. `SessionId` is the device's id type; `InitCapacity` bounds the
/// number of init messages that are replayed after a reset.
template <typename SessionId, uint8_t InitCapacity>
class SessionMonitor {
 public:
  /// Key the client uses to find an init message it keeps.
  using InitKey = uint16_t;

  /// Kinds of actions `poll` asks for.
  enum class ActionKind : uint8_t {
    none,            ///< Nothing to do now.
    send_reset,      ///< Send the protocol's Reset message.
    reset_detected,  ///< Tell the application: the device restarted (session id changed).
    replay_init,     ///< Send the init message registered under `key`.
    established,     ///< Tell the application: the session is initialised; `session_id()` holds it.
  };
  /// One action.
  struct Action {
    ActionKind kind = ActionKind::none;  ///< What to do.
    InitKey key = 0;                     ///< Init to re-send (for `replay_init`).
  };

  /// Monitor with `timing`; `counters` (outliving it) receives resets and Reset re-sends (as retries).
  SessionMonitor(const SessionTiming& timing, LinkCounters& counters) : timing_(timing), counters_(&counters) {}

  /// Adds an init to replay after every reset, after those registered before. Registering a key again
  /// keeps its place. `Status::busy` when `InitCapacity` inits are registered.
  Status register_init(InitKey key) {
    for (uint8_t i = 0; i < init_count_; ++i) {
      if (inits_[i] == key) return Status::ok;
    }
    if (init_count_ == InitCapacity) return Status::busy;
    inits_[init_count_++] = key;
    return Status::ok;
  }
  /// Number of registered inits.
  uint8_t init_count() const { return init_count_; }

  /// Begins the handshake: the next `poll` asks for a Reset.
  void start(Millis now) {
    (void)now;
    enter_awaiting();
  }

  /// The device acknowledged the Reset we sent (with `require_reset_ack`: from now on a ResetEvent is the
  /// answer to it).
  void on_reset_acknowledged(Millis now) {
    (void)now;
    if (state_ == SessionState::awaiting_reset_event) reset_acked_ = true;
  }

  /// The device announced a fresh session (ResetEvent).
  void on_reset_event(SessionId id, Millis now) {
    (void)now;
    switch (state_) {
      case SessionState::idle:
        break;  // not started: nothing to initialise yet
      case SessionState::awaiting_reset_event:
        // Before our Reset was acknowledged, this announces a boot that our Reset is about to end.
        if (timing_.require_reset_ack && !reset_acked_) break;
        adopt(id);
        break;
      case SessionState::replaying:
      case SessionState::established:
        if (id != session_id_) detect_reset();
        break;
    }
  }

  /// The device reported its current session (ArduinoInfo). A different id than the stored one while a
  /// session is set up means the device restarted without us seeing its ResetEvent.
  void on_session_report(SessionId id, Millis now) {
    (void)now;
    if ((state_ == SessionState::replaying || state_ == SessionState::established) && id != session_id_) {
      detect_reset();
    }
  }

  /// The device showed that it no longer holds what the session set up (the proxy device refuses a control
  /// for want of the init it acknowledged): it restarted and the ResetEvent that said so was lost. Treated
  /// as a changed session id, without waiting for the next report to carry it.
  void on_state_lost(Millis now) {
    (void)now;
    if (state_ == SessionState::established) detect_reset();
  }

  /// Next action. Call until it returns `ActionKind::none`.
  Action poll(Millis now) {
    Action action;
    if (reset_detected_pending_) {
      reset_detected_pending_ = false;
      action.kind = ActionKind::reset_detected;
      return action;
    }
    if (state_ == SessionState::awaiting_reset_event) {
      if (reset_pending_ || reset_deadline_.expired(now)) {
        if (!reset_pending_) ++counters_->retries;  // an unanswered Reset
        reset_pending_ = false;
        reset_acked_ = false;  // the new Reset needs its own ack
        reset_deadline_.arm(now, timing_.reset_timeout);
        action.kind = ActionKind::send_reset;
      }
      return action;
    }
    if (state_ == SessionState::replaying) {
      if (replay_next_ < init_count_) {
        action.kind = ActionKind::replay_init;
        action.key = inits_[replay_next_++];
        return action;
      }
      state_ = SessionState::established;
      action.kind = ActionKind::established;
    }
    return action;
  }

  /// When `poll` must be called again at the latest (the Reset re-send); disarmed when nothing is timed.
  Deadline next_wakeup() const {
    return state_ == SessionState::awaiting_reset_event ? reset_deadline_ : Deadline();
  }
  /// Current state.
  SessionState state() const { return state_; }
  /// True once a session id is stored (from the first ResetEvent on).
  bool has_session() const { return has_session_; }
  /// The stored session id; meaningful when `has_session()`.
  SessionId session_id() const { return session_id_; }

 private:
  void enter_awaiting() {
    state_ = SessionState::awaiting_reset_event;
    reset_pending_ = true;
    reset_acked_ = false;
    reset_deadline_.disarm();
  }
  void detect_reset() {
    ++counters_->resets;
    reset_detected_pending_ = true;
    enter_awaiting();
  }
  void adopt(SessionId id) {
    session_id_ = id;
    has_session_ = true;
    state_ = SessionState::replaying;
    replay_next_ = 0;
    reset_deadline_.disarm();
  }

  SessionTiming timing_;
  LinkCounters* counters_;
  SessionState state_ = SessionState::idle;
  SessionId session_id_ = SessionId();
  bool has_session_ = false;
  bool reset_pending_ = false;
  bool reset_acked_ = false;
  bool reset_detected_pending_ = false;
  Deadline reset_deadline_;
  InitKey inits_[InitCapacity] = {};
  uint8_t init_count_ = 0;
  uint8_t replay_next_ = 0;
};

}  // namespace session
}  // namespace tether
