/// @file session_policy.hpp
/// Romi's policy for the session engine (core/session/request_table.hpp) and its default timing.
///
/// Romi is synchronous: one request in flight, 8-bit ids that wrap (the reference host starts after 255,
/// so the first id is 0). A reply with code 0 succeeds; envelope errors -1..-6 ask for the same bytes
/// again (at most 3 sends); any other code is delivered. By default a silent attempt is not re-sent (the
/// device may have executed it: re-sending would give the reference firmware's -15), it times out;
/// `retry_on_timeout` re-sends it, for Tether firmware (it answers a repeated id from its reply cache).
/// Log lines and stale frames restart the 1 s read window, but one call never exceeds the 2 s budget.
#pragma once

#include <stdint.h>

#include "tether/core/session/request_table.hpp"
#include "tether/romi/errors.hpp"
#include "tether/romi/limits.hpp"

namespace tether {
namespace romi {

/// RequestTable policy.
struct SessionPolicy {
  using Id = uint8_t;    ///< Two hex digits on the wire.
  using Code = int16_t;  ///< First value of a response.
  /// Code 0 completes the call with `ok`.
  static bool is_success(Code code) { return code == 0; }
  /// Envelope errors: the frame was damaged, re-send it.
  static bool is_retryable(Code code) { return is_envelope_error(code); }
};

/// The spec's timing: 1 s per attempt, 2 s per call, 3 sends, log lines re-arm the attempt window.
inline session::CallTiming default_call_timing() {
  session::CallTiming timing;
  timing.attempt_timeout = kControllerDeadlineMs;
  timing.call_budget = kHostCallBudgetMs;
  timing.max_attempts = 3;
  timing.retry_on_timeout = false;
  timing.activity_rearms_attempt = true;
  return timing;
}

/// The host's request table: one call in flight.
using RequestTable = session::RequestTable<SessionPolicy, 1>;

}  // namespace romi
}  // namespace tether
