/// @file session_policy.hpp
/// The proxy protocol's policy for the session engine (core/session/request_table.hpp) and its ack
/// timing: what the host client applies to every message, kept here so that it is portable, public and
/// tested on its own with a fake clock (codecs/proxy/tests/session_policy_test.cpp).
///
/// Every message carries a 32-bit messageId and the device acks it; an ack carries no status (code 0 =
/// acked), so nothing is re-sent on a reply. A silent attempt is re-sent with the same id
/// (`retry_on_timeout`): the device's duplicate filter remembers the last ids it executed, so a message
/// whose ack was lost does not run twice. The attempt window is the time both frames (the message and
/// its ack) take on the wire plus a processing margin; the budget (1 s) counts from the first send.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/session/request_table.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/encoder.hpp"

namespace tether {
namespace proxy {

/// RequestTable policy: messageIds, acks.
struct SessionPolicy {
  using Id = uint32_t;  ///< messageId.
  using Code = uint8_t;  ///< `kAcked` or `kRefused` (the ack's `refused` flag).
  /// An ack that says the device acted on the message.
  static constexpr Code kAcked = 0;
  /// An ack of a message the device did not act on (completes it with an error, not with success).
  static constexpr Code kRefused = 1;
  /// An ack completes the message.
  static bool is_success(Code code) { return code == 0; }
  /// Nothing in an ack asks for a re-send.
  static bool is_retryable(Code) { return false; }
};

/// Messages in flight at once (the device's duplicate filter remembers 8).
constexpr uint8_t kMaxInFlight = 8;
/// Bytes of the longest ack frame (`ArduinoOut{ack{messageId, refused}}`, 11-byte payload), delimiters
/// included.
constexpr size_t kAckFrameBytes = max_frame_size(11);

/// What the attempt window and the budget depend on; the protocol's values by default.
struct AckTiming {
  /// Link speed (the transport sets the real speed). 0 is invalid.
  uint32_t baud = 115200;
  /// Bits a byte takes on the wire (8N1 is 10; 11 leaves a margin). >= 1.
  uint32_t bits_per_byte = 11;
  /// Added to the wire time of frame + ack: device processing, OS and USB-serial latency, a device frame
  /// already being sent.
  Duration processing_margin = 50;
  /// Total time from a message's first send to its ack, all re-sends included. >= 1.
  Duration send_budget = 1000;
  /// Frames sent per message at most, the first included (the budget is normally the bound). >= 1.
  uint8_t max_sends = 255;
};

/// The attempt window of a frame of `frame_bytes`:
/// `ceil((frame_bytes + kAckFrameBytes) * bits_per_byte * 1000 / baud) + processing_margin`, saturated at
/// 2^31 - 1 ms.
Duration ack_timeout(const AckTiming& timing, size_t frame_bytes);

/// The engine's timing while the longest frame in flight has `longest_frame` bytes (the engine arms
/// every window with one timing, so no message waits less than its own): its `ack_timeout`, the send
/// budget, `max_sends` attempts, re-send on silence, no re-arming on other traffic.
session::CallTiming call_timing(const AckTiming& timing, size_t longest_frame);

/// The host's request table.
using RequestTable = session::RequestTable<SessionPolicy, kMaxInFlight>;

}  // namespace proxy
}  // namespace tether
