// ManualClock: timers whose waits complete when a test advances the clock.
#include "tether/client/testing/manual_clock.hpp"

#include <boost/asio/error.hpp>
#include <boost/asio/post.hpp>

#include <algorithm>
#include <thread>
#include <utility>

namespace tether::client::testing {

struct ManualClock::Wait {
  const Timer* owner = nullptr;
  Millis at = 0;
  LinkTimer::Handler handler;
  boost::asio::any_io_executor executor;
};

namespace {
void complete(boost::asio::any_io_executor executor, LinkTimer::Handler handler, boost::system::error_code error) {
  boost::asio::post(executor, [handler = std::move(handler), error]() mutable { handler(error); });
}
}  // namespace

class ManualClock::Timer final : public LinkTimer {
 public:
  Timer(std::shared_ptr<ManualClock> clock, boost::asio::any_io_executor executor)
      : clock_(std::move(clock)), executor_(std::move(executor)) {}
  ~Timer() override { cancel(); }

  void wait_until(Millis at, Handler handler) override {
    cancel();
    auto wait = std::make_shared<Wait>();
    wait->owner = this;
    wait->at = at;
    wait->handler = std::move(handler);
    wait->executor = executor_;
    std::unique_lock lock(clock_->mutex_);
    if (tick_reached(clock_->now_, at)) {
      lock.unlock();
      complete(executor_, std::move(wait->handler), {});
      return;
    }
    clock_->waits_.push_back(std::move(wait));
  }

  void cancel() override {
    std::vector<std::shared_ptr<Wait>> cancelled;
    {
      std::lock_guard lock(clock_->mutex_);
      auto& waits = clock_->waits_;
      const auto mine = std::stable_partition(waits.begin(), waits.end(), [this](const auto& w) { return w->owner != this; });
      cancelled.assign(std::make_move_iterator(mine), std::make_move_iterator(waits.end()));
      waits.erase(mine, waits.end());
    }
    for (auto& wait : cancelled) complete(wait->executor, std::move(wait->handler), boost::asio::error::operation_aborted);
  }

 private:
  std::shared_ptr<ManualClock> clock_;
  boost::asio::any_io_executor executor_;
};

std::shared_ptr<ManualClock> ManualClock::create(Millis start) {
  return std::shared_ptr<ManualClock>(new ManualClock(start));
}

Millis ManualClock::now() const {
  std::lock_guard lock(mutex_);
  return now_;
}

std::unique_ptr<LinkTimer> ManualClock::make_timer(const boost::asio::any_io_executor& executor) {
  return std::make_unique<Timer>(shared_from_this(), executor);
}

void ManualClock::advance(Duration by) {
  Millis target = 0;
  {
    std::lock_guard lock(mutex_);
    target = static_cast<Millis>(now_ + by);
  }
  advance_to(target);
}

void ManualClock::advance_to(Millis instant) {
  std::vector<std::shared_ptr<Wait>> due;
  {
    std::lock_guard lock(mutex_);
    if (tick_difference(instant, now_) <= 0) return;
    now_ = instant;
    const auto later = std::stable_partition(waits_.begin(), waits_.end(),
                                             [this](const auto& w) { return !tick_reached(now_, w->at); });
    due.assign(std::make_move_iterator(later), std::make_move_iterator(waits_.end()));
    waits_.erase(later, waits_.end());
  }
  std::stable_sort(due.begin(), due.end(), [](const auto& a, const auto& b) { return tick_difference(a->at, b->at) < 0; });
  for (auto& wait : due) complete(wait->executor, std::move(wait->handler), {});
}

std::size_t ManualClock::pending() const {
  std::lock_guard lock(mutex_);
  return waits_.size();
}

bool ManualClock::next_due(Millis& at) const {
  std::lock_guard lock(mutex_);
  if (waits_.empty()) return false;
  at = waits_.front()->at;
  for (const auto& wait : waits_) {
    if (tick_difference(wait->at, at) < 0) at = wait->at;
  }
  return true;
}

bool ManualClock::wait_for_due(Millis at, Millis& seen, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (!next_due(seen)) {
      seen = now();
    } else if (seen == at) {
      return true;
    }
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

bool ManualClock::advance_to_due(Millis at, Millis& seen, std::chrono::milliseconds timeout) {
  if (!wait_for_due(at, seen, timeout)) return false;
  advance_to(at);
  return true;
}

bool ManualClock::advance_to_next(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  Millis at = 0;
  while (!next_due(at)) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  advance_to(at);
  return true;
}

bool ManualClock::advance_until(const std::function<bool()>& done, std::chrono::milliseconds timeout,
                                Duration max_step) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    Millis at = 0;
    if (next_due(at)) {
      const Millis current = now();
      if (max_step != 0 && tick_difference(at, current) > static_cast<std::int32_t>(max_step)) {
        at = static_cast<Millis>(current + max_step);
        std::this_thread::sleep_for(std::chrono::milliseconds(1));  // let the client catch up
      }
      advance_to(at);
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  return true;
}

}  // namespace tether::client::testing
