// VirtualUnoClock: link timers that poll a board's simulated time on asio steady_timers.
#include "tether/transports/virtual_uno_clock.hpp"

#include <boost/asio/error.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include <algorithm>
#include <cstdint>
#include <utility>

#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::transports {

namespace {

Millis simulated_millis(const VirtualUno& board) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(board.simulated_time()).count();
  return static_cast<Millis>(static_cast<std::uint64_t>(ms));
}

void post_completion(const boost::asio::any_io_executor& executor, client::LinkTimer::Handler handler,
                     boost::system::error_code error) {
  boost::asio::post(executor, [handler = std::move(handler), error]() mutable { handler(error); });
}

class SimulatedTimer final : public client::LinkTimer {
 public:
  SimulatedTimer(std::shared_ptr<const VirtualUno> board, VirtualUnoClockOptions options,
                 const boost::asio::any_io_executor& executor)
      : board_(std::move(board)),
        options_(options),
        executor_(executor),
        timer_(executor),
        wait_(std::make_shared<Wait>()) {}

  ~SimulatedTimer() override { cancel(); }

  void wait_until(Millis at, Handler handler) override {
    cancel();
    wait_->handler = std::move(handler);
    wait_->at = at;
    poll();
  }

  void cancel() override {
    ++wait_->generation;  // a poll already queued finds a newer generation and does nothing
    timer_.cancel();
    if (wait_->handler) {
      post_completion(executor_, std::exchange(wait_->handler, Handler()), boost::asio::error::operation_aborted);
    }
  }

 private:
  // The pending wait, shared (weakly) with the polls in flight so that a poll outliving the timer is a no-op.
  struct Wait {
    Handler handler;
    Millis at = 0;
    std::uint64_t generation = 0;
  };

  // Completes the wait when the board's time reached its instant, or looks again after the remaining
  // simulated time (as wall time, capped at one poll step).
  void poll() {
    const std::int32_t left = tick_difference(wait_->at, simulated_millis(*board_));
    if (left <= 0) {
      post_completion(executor_, std::exchange(wait_->handler, Handler()), {});
      return;
    }
    const auto remaining = std::chrono::microseconds(std::chrono::milliseconds(left));
    const auto step = std::max(std::chrono::microseconds(1), std::min(remaining, options_.poll_step));
    timer_.expires_after(step);
    timer_.async_wait([this, weak = std::weak_ptr<Wait>(wait_), generation = wait_->generation](
                          boost::system::error_code error) {
      const std::shared_ptr<Wait> wait = weak.lock();
      if (error || !wait || wait->generation != generation || !wait->handler) return;
      poll();  // the wait is still ours: `this` is alive (its destructor bumps the generation first)
    });
  }

  std::shared_ptr<const VirtualUno> board_;
  VirtualUnoClockOptions options_;
  boost::asio::any_io_executor executor_;
  boost::asio::steady_timer timer_;
  std::shared_ptr<Wait> wait_;
};

}  // namespace

VirtualUnoClock::VirtualUnoClock(std::shared_ptr<const VirtualUno> board, VirtualUnoClockOptions options)
    : board_(std::move(board)), options_(options) {}

std::shared_ptr<VirtualUnoClock> VirtualUnoClock::create(std::shared_ptr<const VirtualUno> board,
                                                         VirtualUnoClockOptions options) {
  return std::make_shared<VirtualUnoClock>(std::move(board), options);
}

std::shared_ptr<VirtualUnoClock> VirtualUnoClock::create(const VirtualUno& board, VirtualUnoClockOptions options) {
  // A non-owning pointer (aliasing an empty one): the caller keeps the board alive.
  return create(std::shared_ptr<const VirtualUno>(std::shared_ptr<const VirtualUno>(), &board), options);
}

std::shared_ptr<VirtualUnoClock> VirtualUnoClock::create(const std::shared_ptr<VirtualUnoStream>& stream,
                                                         VirtualUnoClockOptions options) {
  // Aliasing the stream: the board lives as long as the stream that owns it.
  return create(std::shared_ptr<const VirtualUno>(stream, &stream->board()), options);
}

Millis VirtualUnoClock::now() const { return simulated_millis(*board_); }

std::unique_ptr<client::LinkTimer> VirtualUnoClock::make_timer(const boost::asio::any_io_executor& executor) {
  return std::make_unique<SimulatedTimer>(board_, options_, executor);
}

}  // namespace tether::transports
