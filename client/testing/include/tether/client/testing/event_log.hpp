/// @file event_log.hpp
/// Records the events of a client (`<codec>::Event`, a `std::variant` of event structs) for a test: one
/// recorder for every client's event model.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <variant>
#include <vector>

namespace tether::client::testing {

/// Every event a client delivered, in order; tests wait for the ones they expect. Handlers share its
/// state, so an event arriving after the log is gone is harmless.
template <typename Event>
class EventLog {
 public:
  /// A handler that records into this log (pass it to the client's constructor or `on_event`).
  std::function<void(const Event&)> handler() {
    return [state = state_](const Event& event) {
      {
        std::lock_guard lock(state->mutex);
        state->events.push_back(event);
      }
      state->changed.notify_all();
    };
  }
  /// Every event so far.
  std::vector<Event> all() const {
    std::lock_guard lock(state_->mutex);
    return state_->events;
  }
  /// The events of type T so far.
  template <typename T>
  std::vector<T> of() const {
    std::lock_guard lock(state_->mutex);
    std::vector<T> found;
    for (const auto& event : state_->events) {
      if (const T* typed = std::get_if<T>(&event)) found.push_back(*typed);
    }
    return found;
  }
  /// Waits until `count` events of type T were recorded; false after `timeout`.
  template <typename T>
  bool wait_for(std::size_t count = 1, std::chrono::milliseconds timeout = std::chrono::milliseconds(10000)) const {
    std::unique_lock lock(state_->mutex);
    return state_->changed.wait_for(lock, timeout, [&] {
      std::size_t seen = 0;
      for (const auto& event : state_->events) {
        if (std::holds_alternative<T>(event)) ++seen;
      }
      return seen >= count;
    });
  }

 private:
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<Event> events;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace tether::client::testing
