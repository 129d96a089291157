/// @file request_table.hpp
/// Host half of the session engine: requests in flight, their deadlines, retries and outcomes.
///
/// Sans-I/O. The client (a codec's host client) calls:
///   - `begin(now)` before sending a request; it allocates the wire id and arms the deadlines;
///   - `on_reply(id, code, now)` for every decoded reply; the verdict says complete / re-send / stale;
///   - `on_activity(now)` for any other frame from the device (log lines, unsolicited messages);
///   - `poll(now)` whenever its timer fires, until it returns `idle`; then re-arm the timer at `next_wakeup()`;
///   - `cancel(id)` when the application gives up.
/// The table never touches bytes: on `resend` the client writes the same encoded frame again (same id).
///
/// Rules (each has a unit test in core/tests/request_table_test.cpp):
///   1. Ids come from a wrapping sequence of the policy's id type (mod 256 for Romi, 32-bit for the proxy);
///      an id still in flight is skipped.
///   2. Each attempt has a deadline (`attempt_timeout`), each call a total budget (`call_budget`) that
///      bounds all attempts, re-sends and waits for log lines or stale frames together.
///   3. A reply is retried (same id) only if `Policy::is_retryable(code)`, attempts remain and budget is left.
///      An attempt that times out is retried only when `retry_on_timeout` is set.
///   4. A reply whose id is not in flight is stale: counted, dropped, never attributed to another call.
///   5. Every call gets exactly one completion: ok, remote_error, timeout or cancelled. Its slot is free
///      the moment the completion is returned.
///
/// Policy concept (one per codec):
/// @code
///   struct Policy {
///     using Id = uint8_t;                         // unsigned; wraps like the wire ids
///     using Code = int16_t;                       // status carried by a reply
///     static bool is_success(Code code);          // reply completes the call with `ok`
///     static bool is_retryable(Code code);        // reply asks for a re-send of the same frame
///   };
/// @endcode
#pragma once

#include <stdint.h>

#include "tether/core/counters.hpp"
#include "tether/core/status.hpp"
#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// Timing and retry rules of calls; runtime values so applications can configure them per device.
struct CallTiming {
  Duration attempt_timeout = 1000;       ///< Wait for a reply to one attempt (Romi: 1 s).
  Duration call_budget = 2000;           ///< Total time of a call, all attempts included (Romi: 2 s).
  uint8_t max_attempts = 3;              ///< Sends per call, the first included (>= 1).
  bool retry_on_timeout = false;         ///< Re-send when an attempt times out (proxy: true, Romi: false).
  bool activity_rearms_attempt = false;  ///< Any frame from the device restarts the attempt window (Romi).
};

/// How a call ended. Delivered exactly once per call.
enum class CallOutcome : uint8_t {
  ok,            ///< A reply with a success code arrived.
  remote_error,  ///< A reply with a non-retryable code arrived, or retries ran out on a retryable one.
  timeout,       ///< The attempt window or the call budget ran out.
  cancelled,     ///< The caller cancelled the call.
};

/// Short English name of an outcome.
inline const char* to_string(CallOutcome outcome) {
  switch (outcome) {
    case CallOutcome::ok: return "ok";
    case CallOutcome::remote_error: return "remote error";
    case CallOutcome::timeout: return "timed out";
    case CallOutcome::cancelled: return "cancelled";
  }
  return "unknown outcome";
}

/// Requests in flight for one device. `Capacity` is the number of concurrent calls (1 for Romi).
template <typename Policy, uint8_t Capacity>
class RequestTable {
  static_assert(Capacity >= 1, "a request table needs at least one slot");

 public:
  /// Wire id type of the codec.
  using Id = typename Policy::Id;
  /// Reply status type of the codec.
  using Code = typename Policy::Code;

  /// The end of one call.
  struct Completion {
    Id id = 0;                                ///< Wire id of the call.
    CallOutcome outcome = CallOutcome::ok;    ///< How it ended.
    Code code = Code();                       ///< Last reply code (meaningful for ok and remote_error).
    uint8_t attempts = 0;                     ///< Frames sent for this call (first send included).
  };

  /// What the client must do with a reply.
  enum class Verdict : uint8_t {
    completed,  ///< Deliver `completion` to the caller.
    resend,     ///< Write the call's frame again (same bytes, same id).
    stale,      ///< Drop it: no call with this id is in flight.
  };
  /// Answer of `on_reply`.
  struct ReplyResult {
    Verdict verdict = Verdict::stale;  ///< What to do.
    Completion completion;             ///< Valid when `verdict == completed`.
  };

  /// What `poll` asks the client to do.
  enum class Action : uint8_t {
    idle,      ///< Nothing is due; re-arm the timer at `next_wakeup()`.
    resend,    ///< Write the frame of call `id` again.
    complete,  ///< Deliver `completion`.
  };
  /// Answer of `poll`.
  struct Step {
    Action action = Action::idle;  ///< What to do.
    Id id = 0;                     ///< Call concerned (resend and complete).
    Completion completion;         ///< Valid when `action == complete`.
  };

  /// Table with `timing`; ids start after `last_id` (Romi's reference host starts after 255, so at 0).
  /// `counters` must outlive the table; it receives stale, retries and timeouts.
  RequestTable(const CallTiming& timing, Id last_id, LinkCounters& counters)
      : timing_(timing), last_id_(last_id), counters_(&counters) {}

  /// Changes the timing. The call budget is fixed when a call begins; the attempt window, `max_attempts`
  /// and the retry rules apply from the next window armed, for calls already in flight too.
  void set_timing(const CallTiming& timing) { timing_ = timing; }
  /// Current timing.
  const CallTiming& timing() const { return timing_; }

  /// Starts a call with the next free id. `Status::busy` when `Capacity` calls are in flight.
  Result<Id> begin(Millis now) {
    if (in_flight() == Capacity) return Status::busy;
    Id id = static_cast<Id>(last_id_ + 1);
    while (find(id) != nullptr) id = static_cast<Id>(id + 1);  // ends: fewer than Capacity ids are taken
    last_id_ = id;
    return begin_with(id, now);
  }

  /// Starts a call with a caller-chosen id (protocols whose replies are matched by type, e.g. Elcano).
  /// `Status::busy` when the table is full or `id` is already in flight.
  Result<Id> begin_with(Id id, Millis now) {
    if (find(id) != nullptr) return Status::busy;
    Slot* slot = free_slot();
    if (slot == nullptr) return Status::busy;
    slot->used = true;
    slot->id = id;
    slot->attempts = 1;
    slot->call_deadline.arm(now, timing_.call_budget);
    arm_attempt(*slot, now);
    return id;
  }

  /// Classifies a reply carrying `id` and `code`.
  ReplyResult on_reply(Id id, Code code, Millis now) {
    ReplyResult result;
    Slot* slot = find(id);
    if (slot == nullptr) {
      ++counters_->stale;
      result.verdict = Verdict::stale;
      return result;
    }
    if (Policy::is_success(code)) {
      result.verdict = Verdict::completed;
      result.completion = finish(*slot, CallOutcome::ok, code);
      return result;
    }
    if (Policy::is_retryable(code) && can_retry(*slot, now)) {
      retry(*slot, now);
      result.verdict = Verdict::resend;
      return result;
    }
    result.verdict = Verdict::completed;
    result.completion = finish(*slot, CallOutcome::remote_error, code);
    return result;
  }

  /// Notes a frame from the device that is not a reply (log line, stale reply, event). With
  /// `activity_rearms_attempt`, every call's attempt window restarts, still bounded by its budget.
  void on_activity(Millis now) {
    if (!timing_.activity_rearms_attempt) return;
    for (Slot& slot : slots_) {
      if (slot.used) arm_attempt(slot, now);
    }
  }

  /// Handles expired deadlines, one at a time. Call until it returns `Action::idle`.
  Step poll(Millis now) {
    Step step;
    for (Slot& slot : slots_) {
      if (!slot.used) continue;
      if (slot.call_deadline.expired(now)) {
        ++counters_->timeouts;
        step.action = Action::complete;
        step.id = slot.id;
        step.completion = finish(slot, CallOutcome::timeout, Code());
        return step;
      }
      if (slot.attempt_deadline.expired(now)) {
        if (timing_.retry_on_timeout && can_retry(slot, now)) {
          retry(slot, now);
          step.action = Action::resend;
          step.id = slot.id;
          return step;
        }
        ++counters_->timeouts;
        step.action = Action::complete;
        step.id = slot.id;
        step.completion = finish(slot, CallOutcome::timeout, Code());
        return step;
      }
    }
    return step;
  }

  /// Cancels call `id`. `Status::not_found` when it is not in flight (already completed: no second
  /// completion is ever produced).
  Result<Completion> cancel(Id id) {
    Slot* slot = find(id);
    if (slot == nullptr) return Status::not_found;
    return finish(*slot, CallOutcome::cancelled, Code());
  }

  /// Earliest deadline of any call in flight (disarmed when none): when the client must call `poll`.
  Deadline next_wakeup() const {
    Deadline earliest;
    for (const Slot& slot : slots_) {
      if (!slot.used) continue;
      const Millis at = tick_earlier(slot.attempt_deadline.at(), slot.call_deadline.at());
      if (!earliest.armed() || tick_difference(at, earliest.at()) < 0) earliest.arm_at(at);
    }
    return earliest;
  }

  /// Calls in flight.
  uint8_t in_flight() const {
    uint8_t count = 0;
    for (const Slot& slot : slots_) count = static_cast<uint8_t>(count + (slot.used ? 1 : 0));
    return count;
  }
  /// True when call `id` is in flight.
  bool contains(Id id) const { return find(id) != nullptr; }
  /// Attempts made so far by call `id` (0 when not in flight).
  uint8_t attempts(Id id) const {
    const Slot* slot = find(id);
    return slot == nullptr ? 0 : slot->attempts;
  }

 private:
  struct Slot {
    bool used = false;
    Id id = 0;
    uint8_t attempts = 0;
    Deadline attempt_deadline;
    Deadline call_deadline;
  };

  Slot* find(Id id) {
    for (Slot& slot : slots_) {
      if (slot.used && slot.id == id) return &slot;
    }
    return nullptr;
  }
  const Slot* find(Id id) const {
    for (const Slot& slot : slots_) {
      if (slot.used && slot.id == id) return &slot;
    }
    return nullptr;
  }
  Slot* free_slot() {
    for (Slot& slot : slots_) {
      if (!slot.used) return &slot;
    }
    return nullptr;
  }
  void arm_attempt(Slot& slot, Millis now) {
    // The attempt window never reaches past the call budget.
    const Millis attempt_end = static_cast<Millis>(now + timing_.attempt_timeout);
    slot.attempt_deadline.arm_at(tick_earlier(attempt_end, slot.call_deadline.at()));
  }
  bool can_retry(const Slot& slot, Millis now) const {
    return slot.attempts < timing_.max_attempts && !slot.call_deadline.expired(now);
  }
  void retry(Slot& slot, Millis now) {
    ++slot.attempts;
    ++counters_->retries;
    arm_attempt(slot, now);
  }
  Completion finish(Slot& slot, CallOutcome outcome, Code code) {
    Completion completion;
    completion.id = slot.id;
    completion.outcome = outcome;
    completion.code = code;
    completion.attempts = slot.attempts;
    slot.used = false;
    return completion;
  }

  CallTiming timing_;
  Id last_id_;
  LinkCounters* counters_;
  Slot slots_[Capacity];
};

}  // namespace session
}  // namespace tether
