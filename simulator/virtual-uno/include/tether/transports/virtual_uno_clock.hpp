/// @file virtual_uno_clock.hpp
/// A `client::LinkClock` on a virtual board's simulated time: host deadlines (a client's attempt window, its call
/// budget, a ping period) measured on the same clock as the firmware's own timeouts.
///
/// When to use it: tests and simulations where a host deadline must share the device's clock. A board
/// paced in real time falls behind the wall clock on a loaded machine (or under the sanitizers), so with
/// the steady clock a host's 1 s window can end before the firmware's 1 s has; on this clock both measure
/// the same simulated second, whatever the load. Programs talking to real hardware keep the steady clock.
///
/// Granularity: simulated time is read with `VirtualUno::simulated_time()`, which off the simulation thread
/// is updated at every quantum boundary (1 ms by default). A wait polls it on an asio steady_timer in wall
/// steps of at most `VirtualUnoClockOptions::poll_step` (each step is the remaining simulated time, capped),
/// and completes at the first poll that sees the instant reached: never early, late by at most one poll
/// step of wall time plus scheduling. In simulated time that is about one step for a real-time board; for
/// a `Pacing::fast` board running N times faster than real time it is up to N steps (a fast board runs far
/// ahead of any host anyway). A board that is stopped (or driven by `run_for()` and not advanced) stops
/// the clock: waits stay pending until it moves on or they are cancelled.
#pragma once

#include <chrono>
#include <memory>

#include "tether/client/link_clock.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::transports {

class VirtualUnoStream;

/// Options of a `VirtualUnoClock`.
struct VirtualUnoClockOptions {
  /// Longest wall-clock wait between two looks at the board's time while a wait is pending (at least 1 us).
  std::chrono::microseconds poll_step{std::chrono::milliseconds(2)};
};

/// The simulated time of one board (or of the lockstep group it belongs to) as a `client::LinkClock`: `now()` is
/// the board's simulated milliseconds since its creation, truncated to 32 bits (wrap-safe like every link
/// clock). Thread-safe; give it to a client through its `Options::clock`.
class VirtualUnoClock final : public client::LinkClock {
 public:
  /// The clock of `board`, which the clock and its timers keep alive.
  static std::shared_ptr<VirtualUnoClock> create(std::shared_ptr<const VirtualUno> board,
                                                 VirtualUnoClockOptions options = {});
  /// The clock of a board the caller owns and keeps alive longer than the clock and every timer.
  static std::shared_ptr<VirtualUnoClock> create(const VirtualUno& board, VirtualUnoClockOptions options = {});
  /// The clock of the board a stream writes to (`stream->board()`; a ring's boards share one time), which
  /// the clock keeps alive through the stream.
  static std::shared_ptr<VirtualUnoClock> create(const std::shared_ptr<VirtualUnoStream>& stream,
                                                 VirtualUnoClockOptions options = {});

  /// The board's simulated time in wrap-safe milliseconds (at most one quantum old off the simulation thread).
  Millis now() const override;
  /// A timer whose waits complete on `executor` once the board's simulated time reaches their instant.
  std::unique_ptr<client::LinkTimer> make_timer(const boost::asio::any_io_executor& executor) override;

  /// Public for std::make_shared; use `create`.
  VirtualUnoClock(std::shared_ptr<const VirtualUno> board, VirtualUnoClockOptions options);

 private:
  std::shared_ptr<const VirtualUno> board_;
  VirtualUnoClockOptions options_;
};

}  // namespace tether::transports
