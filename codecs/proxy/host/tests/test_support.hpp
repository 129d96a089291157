// Shared pieces of the proxy client tests: a client wired to a scripted fake device, short timing, and an
// event recorder.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <variant>
#include <vector>

#include "fake_device.hpp"
#include "tether/proxy/client.hpp"
#include "tether/testing/eventually.hpp"
#include "tether/client/testing/event_log.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/client/testing/manual_clock.hpp"

namespace tether::proxy::testing {

using namespace std::chrono_literals;

/// Bound for "happens promptly": against hangs, never a timing assertion (time is simulated), so wide
/// enough for an ASan build on a 2-core machine at load 25, where a test's steps can take seconds.
inline constexpr auto kPrompt = std::chrono::milliseconds(10000);

/// The step of `Link::advance_until` while progress needs the device's answers: 1 ms of simulated time per
/// step (and a 1 ms pause), so a deadline passes before its answer is back only if the machine stalls for
/// as long as the deadline's whole window of wall time. (Deadline by deadline, the test thread could
/// run a message's re-sends and its budget out between the device's ack and its arrival.)
inline constexpr Duration kStepWithAcks = 1;

/// Primary-mode options for tests: the protocol's shape, scaled down. No pings unless a test wants them
/// (so messageIds are predictable). Time is simulated (`Link`): these are instants a test advances to.
inline Options test_options() {
  Options options;
  options.timing.processing_margin = 150;
  options.timing.send_budget = 1000;
  options.timing.queue_timeout = 2000;
  options.timing.ping_period = 0;
  options.timing.session.reset_timeout = 1000;
  return options;
}

/// Compat-mode options for tests.
inline Options compat_test_options() {
  Options options = Options::compat();
  options.timing.stale_after = 5000;
  return options;
}

/// Records every event; tests wait for the ones they expect.
using EventLog = client::testing::EventLog<Event>;
using ::tether::testing::eventually;

/// A client and a fake device on the two ends of an in-memory pair, on a manual clock: no ack window, budget
/// or ping period passes unless the test advances `clock`, so a loaded machine cannot re-send or time out a
/// message behind a test's back, and timing assertions are on simulated time (the device stamps frames
/// with it).
struct Link {
  Link(boost::asio::any_io_executor executor, Options options, FakeDevice::Script script)
      : clock(client::testing::ManualClock::create()) {
    options.clock = clock;
    auto [host_end, device_end] = transports::InMemoryStream::make_pair(executor);
    device = FakeDevice::start(device_end, options.mode == Mode::primary ? Integrity::crc16 : Integrity::none,
                               std::move(script), clock);
    client.emplace(host_end, options, log.handler());
  }
  ~Link() {
    if (client) client->close();
    device->close();
  }
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  /// Waits for the (next) SessionEstablished: `count` of them in all.
  bool established(std::size_t count = 1) const { return log.wait_for<events::SessionEstablished>(count); }

  /// Advances the clock deadline by deadline until `done()` holds (false if it does not within 10 s of
  /// wall time): for what needs re-sends or timeouts to happen. `max_step` as in
  /// `ManualClock::advance_until` (`kStepWithAcks` when the device's answers must keep up).
  bool advance_until(const std::function<bool()>& done, Duration max_step = 0) const {
    return clock->advance_until(done, std::chrono::milliseconds(10000), max_step);
  }

  /// Advances the clock to `at` once the client's earliest deadline is exactly `at` (it armed that one and
  /// none before it); false, with the instant it did arm in `seen`, otherwise (`ManualClock::wait_for_due`).
  bool advance_to_due(Millis at, Millis& seen) const {
    if (!clock->wait_for_due(at, seen, kPrompt)) return false;
    clock->advance_to(at);
    return true;
  }

  std::shared_ptr<client::testing::ManualClock> clock;
  EventLog log;
  std::shared_ptr<FakeDevice> device;
  std::optional<Client> client;
};

/// Frames the device decoded whose ArduinoIn holds `data_case` (primary).
inline std::vector<DeviceFrame> frames_of(const std::vector<DeviceFrame>& frames, ArduinoIn::DataCase data_case) {
  std::vector<DeviceFrame> found;
  for (const auto& frame : frames) {
    if (frame.decoded && frame.in.data_case() == data_case) found.push_back(frame);
  }
  return found;
}

/// Predicate for FakeDevice::wait_for: at least `count` frames holding `data_case`.
inline std::function<bool(const std::vector<DeviceFrame>&)> has(ArduinoIn::DataCase data_case, std::size_t count = 1) {
  return [data_case, count](const std::vector<DeviceFrame>& frames) { return frames_of(frames, data_case).size() >= count; };
}

/// The result of an asynchronous send, captured for a test.
struct Outcome {
  error_code error;
  SendResult result;
};

/// Collects completions of asynchronous sends (any thread) and counts them. Handlers share its state, so a
/// completion arriving after the collector is gone (a send still pending at the end of a test) is harmless.
class Completions {
 public:
  /// A completion handler recording into slot `index`.
  auto handler(std::size_t index) {
    return [state = state_, index](error_code error, SendResult result) {
      {
        std::lock_guard lock(state->mutex);
        if (state->outcomes.size() <= index) state->outcomes.resize(index + 1);
        state->outcomes[index] = Outcome{error, result};
        ++state->calls;
      }
      state->changed.notify_all();
    };
  }
  /// Waits until `count` completions arrived.
  bool wait_for(std::size_t count, std::chrono::milliseconds timeout = kPrompt) const {
    std::unique_lock lock(state_->mutex);
    return state_->changed.wait_for(lock, timeout, [&] { return state_->calls >= count; });
  }
  /// Completions so far (each handler runs once: equals the number of sends completed).
  std::size_t calls() const {
    std::lock_guard lock(state_->mutex);
    return state_->calls;
  }
  /// The outcome of send `index`.
  Outcome at(std::size_t index) const {
    std::lock_guard lock(state_->mutex);
    return index < state_->outcomes.size() && state_->outcomes[index] ? *state_->outcomes[index] : Outcome{};
  }

 private:
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<std::optional<Outcome>> outcomes;
    std::size_t calls = 0;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace tether::proxy::testing
