// Shared pieces of the Romi client tests: a client wired to a scripted fake device, short timing.
#pragma once

#include <chrono>
#include <functional>
#include <future>
#include <string_view>
#include <variant>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fake_device.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/romi/client.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/transports/in_memory_stream.hpp"

namespace tether::romi::testing {

/// Timing for tests: the spec's shape (attempt window, budget twice as long, 3 sends), scaled down.
inline Options short_timing(Duration attempt_ms = 250, Duration budget_ms = 500) {
  Options options;
  options.timing.attempt_timeout = attempt_ms;
  options.timing.call_budget = budget_ms;
  return options;
}

/// An event handler passing the text of every `events::Log` to `handler`.
inline EventHandler on_log(std::function<void(std::string_view)> handler) {
  return [handler = std::move(handler)](const Event& event) {
    if (const auto* log = std::get_if<events::Log>(&event)) handler(log->text);
  };
}

/// An event handler passing the error of `events::LinkFailed` to `handler`.
inline EventHandler on_link_failed(std::function<void(error_code)> handler) {
  return [handler = std::move(handler)](const Event& event) {
    if (const auto* failed = std::get_if<events::LinkFailed>(&event)) handler(failed->error);
  };
}

/// A client and a fake device on the two ends of an in-memory pair. The client runs on `clock`, a manual
/// clock, unless `options` name another: no attempt window or budget passes behind a test's back, so a
/// loaded machine cannot time a call out; tests about timeouts advance `clock` and assert on its time.
struct Link {
  explicit Link(boost::asio::any_io_executor executor, Options options = short_timing())
      : clock(client::testing::ManualClock::create()) {
    if (!options.clock) options.clock = clock;
    auto [host_end, device_end] = transports::InMemoryStream::make_pair(executor);
    device = FakeDevice::start(device_end);
    client.emplace(host_end, options);
  }
  ~Link() {
    client->close();
    device->close();
  }
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  std::shared_ptr<client::testing::ManualClock> clock;
  std::shared_ptr<FakeDevice> device;
  std::optional<Client> client;
};

/// A call's outcome, captured from its completion handler.
struct Outcome {
  error_code error;
  RomiResponse response;
};

/// Starts `command` (`manual`: in manual form) and returns its outcome to come: a test then moves the
/// manual clock while the call waits, which a blocking call on the test's thread could not.
inline std::future<Outcome> start_call(Client& client, std::string command, bool manual = false) {
  auto promise = std::make_shared<std::promise<Outcome>>();  // shared: the completion may outlive the test's frame
  auto outcome = promise->get_future();
  auto complete = [promise](error_code error, RomiResponse response) {
    promise->set_value({error, std::move(response)});
  };
  if (manual) {
    client.async_call_manual(std::move(command), std::move(complete));
  } else {
    client.async_call(std::move(command), std::move(complete));
  }
  return outcome;
}

/// The request frame a client writes for `payload` with `id`.
inline std::string request_frame(const std::string& payload, std::uint8_t id) {
  std::uint8_t buffer[128];
  const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()), id, buffer);
  return std::string(reinterpret_cast<const char*>(buffer), size.ok() ? size.value() : 0);
}

/// A script answering every good request with `body` (its opcode and id mirrored).
inline FakeDevice::Script answer_with(std::string body) {
  return [body = std::move(body)](const DeviceRequest& request, FakeDevice& device) {
    if (request.error != Error::no_error) return;
    device.send(FakeDevice::response(request.opcode, body, request.manual ? 0 : request.id));
  };
}

}  // namespace tether::romi::testing
