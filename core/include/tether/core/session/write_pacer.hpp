/// @file write_pacer.hpp
/// Flow control without a back channel: a token bucket that keeps a writer within what the receiver at
/// the other end of a one-way link can take (the Elcano ring's problem: the reference wrote at line rate
/// into an Uno whose 64-byte receive buffer is only emptied when its main loop comes round).
///
/// Model of the receiver: it has `receiver_buffer` bytes of receive buffer and empties it at least every
/// `receiver_poll_interval` ms (0: it reads as fast as the line delivers). The pacer is a token bucket of
/// depth C = receiver_buffer / 2 bytes refilled at r bytes per ms, where r is the smaller of the line rate
/// (baud / 10 / 1000) and (receiver_buffer / 2) per poll interval. Rules (core/tests/write_pacer_test.cpp):
///   1. Any window of `receiver_poll_interval` ms is handed at most C + r * T <= receiver_buffer bytes,
///      so a receiver that reads at least that often never overflows.
///   2. Never more than the line rate on average: with a receiver that keeps up, the pacer only smooths.
///   3. The bucket starts full; tokens are kept in thousandths of a byte so slow rates do not round to 0.
///   4. `allowance` never exceeds the depth; `next_allowed` says when `bytes` will be allowed, so a caller
///      arms one timer instead of polling.
///   5. `take(wanted, now)` is `allowance` + `consume` of min(wanted, allowance) in one step, without a
///      32-bit division when the bucket holds `wanted` (the common case: an AVR node forwarding a message).
/// Sans-I/O and portable: the caller passes `now` and writes the bytes itself.
#pragma once

#include <stdint.h>

#include "tether/core/time.hpp"

namespace tether {
namespace session {

/// What the pacer knows about the link and its receiver.
struct LinkPacing {
  uint32_t baud = 115200;               ///< Line speed (10 bits per byte: 8N1).
  uint16_t receiver_buffer = 64;        ///< Receive buffer of the next node (an Uno's: 64 bytes).
  uint16_t receiver_poll_interval = 0;  ///< Longest gap (ms) between the receiver's reads; 0: keeps up.
};

/// Token bucket sized from `LinkPacing`; see the file overview.
class WritePacer {
 public:
  /// Pacer for `pacing`, full at `now`.
  WritePacer(const LinkPacing& pacing, Millis now) { configure(pacing, now); }

  /// Changes the link description; the bucket refills to its new depth at `now`.
  void configure(const LinkPacing& pacing, Millis now) {
    depth_ = static_cast<uint32_t>(pacing.receiver_buffer / 2u) * 1000u;
    if (depth_ < 1000u) depth_ = 1000u;  // always at least one byte
    // Line rate in thousandths of a byte per ms: baud / 10 bytes/s = baud / 10 thousandths per ms.
    uint32_t rate = pacing.baud / 10u;
    if (pacing.receiver_poll_interval != 0) {
      const uint32_t receiver_rate = depth_ / pacing.receiver_poll_interval;
      if (receiver_rate < rate) rate = receiver_rate;
    }
    rate_ = rate == 0 ? 1u : rate;
    // Once per configuration, so that a refill compares instead of dividing (AVR: ~570 cycles a division).
    full_after_ = depth_ / rate_ + 1u;
    depth_bytes_ = static_cast<uint16_t>(depth_ / 1000u);
    tokens_ = depth_;
    last_ = now;
  }

  /// Whole bytes that may be handed to the line at `now`.
  uint16_t allowance(Millis now) {
    refill(now);
    return static_cast<uint16_t>(tokens_ / 1000u);
  }

  /// Takes min(`wanted`, `allowance(now)`) bytes from the bucket and returns that count (rule 5).
  uint16_t take(uint16_t wanted, Millis now) {
    refill(now);
    const uint32_t used = static_cast<uint32_t>(wanted) * 1000u;
    if (used <= tokens_) {
      tokens_ -= used;
      return wanted;
    }
    const uint16_t allowed = static_cast<uint16_t>(tokens_ / 1000u);  // fewer than wanted: rare
    tokens_ -= static_cast<uint32_t>(allowed) * 1000u;
    return allowed;
  }

  /// Records that `bytes` (at most `allowance(now)`) were handed to the line.
  void consume(uint16_t bytes) {
    const uint32_t used = static_cast<uint32_t>(bytes) * 1000u;
    tokens_ = used > tokens_ ? 0u : tokens_ - used;
  }

  /// Instant at which `bytes` will be allowed (never later than one bucket refill; `bytes` above the
  /// depth are treated as the depth). Call after `allowance(now)` or `consume` at `now`.
  Millis next_allowed(uint16_t bytes, Millis now) {
    refill(now);
    uint32_t wanted = static_cast<uint32_t>(bytes) * 1000u;
    if (wanted > depth_) wanted = depth_;
    if (tokens_ >= wanted) return now;
    const uint32_t missing = wanted - tokens_;
    return static_cast<Millis>(now + (missing + rate_ - 1u) / rate_);
  }

  /// Bucket depth in bytes.
  uint16_t depth() const { return depth_bytes_; }
  /// Refill rate in thousandths of a byte per ms (= bytes per s).
  uint32_t rate() const { return rate_; }

 private:
  void refill(Millis now) {
    const int32_t elapsed = tick_difference(now, last_);
    if (elapsed <= 0) return;
    last_ = now;
    const uint32_t ms = static_cast<uint32_t>(elapsed);
    // Saturate before multiplying: a long idle gap must not overflow 32 bits.
    if (ms >= full_after_) {
      tokens_ = depth_;
      return;
    }
    tokens_ += ms * rate_;
    if (tokens_ > depth_) tokens_ = depth_;
  }

  uint32_t depth_ = 0;   // thousandths of a byte
  uint32_t rate_ = 1;    // thousandths of a byte per ms
  uint32_t tokens_ = 0;  // thousandths of a byte
  Millis last_ = 0;
  uint32_t full_after_ = 1;    // ms after which an empty bucket is full again: depth_ / rate_ + 1
  uint16_t depth_bytes_ = 0;   // depth_ in whole bytes
};

}  // namespace session
}  // namespace tether
