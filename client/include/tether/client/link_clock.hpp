/// @file link_clock.hpp
/// The time source of a `ClientLink`: a clock in the session engines' wrap-safe milliseconds and one-shot
/// timers on it. Injectable so that client tests run on a manual clock (`client::testing::ManualClock`)
/// and assert on simulated time; programs use `steady_link_clock()`, the default of every client. Tests and
/// simulations whose host deadlines must share a virtual board's clock use `VirtualUnoClock`
/// (virtual_uno_clock.hpp, Tether::simulator).
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/system/error_code.hpp>

#include <memory>

#include "tether/core/time.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::client {

/// Spelled as in the transports, whose streams the client runtime drives.
namespace asio = boost::asio;
/// The error type of every completion (the streams' and the link's).
using boost::system::error_code;

/// One timer of a link: at most one wait pending at a time.
class LinkTimer {
 public:
  /// Completion of a wait. Contract:
  ///   1. Called exactly once per `wait_until`, on the timer's executor, never inside `wait_until` or
  ///      `cancel`.
  ///   2. With no error when the clock reached the instant; with `operation_aborted` when the wait was
  ///      cancelled, replaced by another `wait_until`, or the timer was destroyed first.
  using Handler = transports::UniqueFunction<void(boost::system::error_code)>;

  virtual ~LinkTimer() = default;
  /// Waits until the clock reads `at` (wrap-safe: an instant up to 2^31 ms in the past completes at once),
  /// replacing the pending wait. Call on the timer's executor.
  virtual void wait_until(Millis at, Handler handler) = 0;
  /// Completes the pending wait, if any, with `operation_aborted`. Call on the timer's executor.
  virtual void cancel() = 0;
};

/// A clock and the factory of its timers. Shared by every link that runs on it.
class LinkClock {
 public:
  virtual ~LinkClock() = default;
  /// The current time in wrap-safe milliseconds. Any thread.
  virtual Millis now() const = 0;
  /// A new timer whose waits complete on `executor` (the link's strand). Any thread.
  virtual std::unique_ptr<LinkTimer> make_timer(const boost::asio::any_io_executor& executor) = 0;
};

/// The steady clock (`std::chrono::steady_clock` in milliseconds, truncated to 32 bits) with asio
/// steady_timers: what every client runs on unless its options name another clock. One shared instance.
std::shared_ptr<LinkClock> steady_link_clock();

}  // namespace tether::client
