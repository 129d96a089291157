/// @file time.hpp
/// Wrap-safe millisecond time for sans-I/O code: callers pass `now`, nothing here reads a clock.
///
/// Tick counters wrap: a 32-bit millisecond counter after 49.7 days, a 16-bit one after 65.5 s. Comparing
/// ticks with `<` breaks at the wrap; comparing the signed difference does not, as long as the two
/// instants are less than half the counter range apart. Every deadline in Tether goes through these
/// helpers, so the engine works across a wrap on both counter widths.
#pragma once

#include <stdint.h>

namespace tether {

/// Milliseconds on the engine's clock (32-bit, wraps). The caller chooses the epoch.
using Millis = uint32_t;
/// A span of milliseconds; must stay below 2^31 so deadlines remain comparable.
using Duration = uint32_t;

/// Signed counterpart of a tick type, used for wrap-safe differences.
template <typename Tick>
struct SignedTick;
/// 16-bit ticks (e.g. a hardware timer or a 16-bit millis counter).
template <>
struct SignedTick<uint16_t> {
  using type = int16_t;  ///< Same width, signed.
};
/// 32-bit ticks (the engine's `Millis`).
template <>
struct SignedTick<uint32_t> {
  using type = int32_t;  ///< Same width, signed.
};

/// `later - earlier` as a signed value, correct across one wrap of the counter.
template <typename Tick>
constexpr typename SignedTick<Tick>::type tick_difference(Tick later, Tick earlier) {
  return static_cast<typename SignedTick<Tick>::type>(static_cast<Tick>(later - earlier));
}

/// True when `now` is at or past `deadline` (wrap-safe).
template <typename Tick>
constexpr bool tick_reached(Tick now, Tick deadline) {
  return tick_difference(now, deadline) >= 0;
}

/// The earlier of two instants (wrap-safe).
template <typename Tick>
constexpr Tick tick_earlier(Tick a, Tick b) {
  return tick_difference(a, b) <= 0 ? a : b;
}

/// A point in time that may or may not be armed. Copyable, no clock inside.
class Deadline {
 public:
  /// Disarmed deadline: never expires.
  constexpr Deadline() : at_(0), armed_(false) {}

  /// Arms the deadline `duration` ms after `now`.
  void arm(Millis now, Duration duration) {
    at_ = static_cast<Millis>(now + duration);
    armed_ = true;
  }
  /// Arms the deadline at the absolute instant `at`.
  void arm_at(Millis at) {
    at_ = at;
    armed_ = true;
  }
  /// Disarms; `expired` is false until armed again.
  void disarm() { armed_ = false; }
  /// True when armed.
  constexpr bool armed() const { return armed_; }
  /// The instant it expires at; meaningful only when armed.
  constexpr Millis at() const { return at_; }
  /// True when armed and `now` is at or past the instant.
  constexpr bool expired(Millis now) const { return armed_ && tick_reached(now, at_); }
  /// Milliseconds left at `now` (0 when expired or disarmed).
  Duration remaining(Millis now) const {
    if (!armed_) return 0;
    const int32_t left = tick_difference(at_, now);
    return left > 0 ? static_cast<Duration>(left) : 0;
  }

 private:
  Millis at_;
  bool armed_;
};

}  // namespace tether
