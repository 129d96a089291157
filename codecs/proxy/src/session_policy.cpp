#include "tether/proxy/session_policy.hpp"

namespace tether {
namespace proxy {

Duration ack_timeout(const AckTiming& timing, size_t frame_bytes) {
  const uint64_t rate = timing.baud == 0 ? 1 : timing.baud;
  const uint64_t bits = static_cast<uint64_t>(frame_bytes + kAckFrameBytes) * timing.bits_per_byte;
  const uint64_t wire_ms = (bits * 1000u + rate - 1u) / rate;
  const uint64_t total = wire_ms + timing.processing_margin;
  return static_cast<Duration>(total < 0x7FFFFFFFu ? total : 0x7FFFFFFFu);
}

session::CallTiming call_timing(const AckTiming& timing, size_t longest_frame) {
  session::CallTiming call;
  call.attempt_timeout = ack_timeout(timing, longest_frame);
  call.call_budget = timing.send_budget;
  call.max_attempts = timing.max_sends;
  call.retry_on_timeout = true;
  call.activity_rearms_attempt = false;
  return call;
}

}  // namespace proxy
}  // namespace tether
