// The steady link clock: asio steady_timers driven by wrap-safe millisecond deadlines.
#include "tether/client/link_clock.hpp"

#include <boost/asio/steady_timer.hpp>

#include <chrono>
#include <cstdint>

namespace tether::client {

namespace {

std::uint64_t steady_milliseconds() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

class SteadyTimer final : public LinkTimer {
 public:
  explicit SteadyTimer(const boost::asio::any_io_executor& executor) : timer_(executor) {}

  void wait_until(Millis at, Handler handler) override {
    // The 32-bit deadline back to a full steady-clock instant through the wrap-safe difference to now.
    const std::uint64_t full = steady_milliseconds();
    const std::int32_t left = tick_difference(at, static_cast<Millis>(full));
    const std::uint64_t due = full + static_cast<std::uint64_t>(left > 0 ? left : 0);
    timer_.expires_at(std::chrono::steady_clock::time_point(std::chrono::milliseconds(due)));
    timer_.async_wait([handler = std::move(handler)](boost::system::error_code error) mutable { handler(error); });
  }

  void cancel() override { timer_.cancel(); }

 private:
  boost::asio::steady_timer timer_;
};

class SteadyLinkClock final : public LinkClock {
 public:
  Millis now() const override { return static_cast<Millis>(steady_milliseconds()); }
  std::unique_ptr<LinkTimer> make_timer(const boost::asio::any_io_executor& executor) override {
    return std::make_unique<SteadyTimer>(executor);
  }
};

}  // namespace

std::shared_ptr<LinkClock> steady_link_clock() {
  static const std::shared_ptr<LinkClock> clock = std::make_shared<SteadyLinkClock>();
  return clock;
}

}  // namespace tether::client
