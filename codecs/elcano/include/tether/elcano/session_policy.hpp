/// @file session_policy.hpp
/// Elcano's policy for the session engine (core/session/request_table.hpp): request/response over a ring.
///
/// Elcano messages carry no id: a request is answered by a message of an agreed type (the reference's
/// test pattern: a goal sent to the ring is answered by a segment). The call's id is therefore the reply
/// type (`begin_with(static_cast<uint8_t>(reply_type), now)`): one call per reply type in flight, and the
/// first captured message of that type completes it. Any message of the type completes the call (the code
/// is unused), so a silent attempt is re-sent (`retry_on_timeout`): on a ring, a lost request and a lost
/// reply look the same, and re-sending a goal or a sensor reading is harmless (they are states, not
/// increments).
#pragma once

#include <stdint.h>

#include "tether/core/session/request_table.hpp"
#include "tether/elcano/message.hpp"

namespace tether {
namespace elcano {

/// RequestTable policy.
struct SessionPolicy {
  using Id = uint8_t;    ///< The reply type's header character.
  using Code = uint8_t;  ///< Unused: any reply of the type succeeds.
  /// Every reply of the awaited type completes the call.
  static bool is_success(Code) { return true; }
  /// Nothing in a reply asks for a re-send.
  static bool is_retryable(Code) { return false; }
};

/// Default timing: 500 ms per attempt (a three-board ring at 115200 answers in a few ms; slow nodes in
/// a 20 ms loop need tens), 3 sends, 2 s per call.
inline session::CallTiming default_call_timing() {
  session::CallTiming timing;
  timing.attempt_timeout = 500;
  timing.call_budget = 2000;
  timing.max_attempts = 3;
  timing.retry_on_timeout = true;
  timing.activity_rearms_attempt = false;
  return timing;
}

/// Call id of a request awaiting `reply` (its header character).
inline uint8_t call_id(Type reply) { return static_cast<uint8_t>(reply); }

/// A node's request table: one call per reply type, so at most four.
using RequestTable = session::RequestTable<SessionPolicy, 4>;

}  // namespace elcano
}  // namespace tether
