// Shared pieces of the Romi client tests: a client wired to a scripted fake device, short timing.
#pragma once

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fake_device.hpp"
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

/// An io_context run by `count` threads (the strand must serialise the client across them).
class IoThreads {
 public:
  explicit IoThreads(unsigned count = 2) : guard_(boost::asio::make_work_guard(io_)) {
    for (unsigned i = 0; i < count; ++i) threads_.emplace_back([this] { io_.run(); });
  }
  ~IoThreads() {
    guard_.reset();
    io_.stop();
    for (auto& thread : threads_) thread.join();
  }
  IoThreads(const IoThreads&) = delete;
  IoThreads& operator=(const IoThreads&) = delete;
  /// Executor of the context.
  boost::asio::any_io_executor executor() { return io_.get_executor(); }

 private:
  boost::asio::io_context io_;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> guard_;
  std::vector<std::thread> threads_;
};

/// A client and a fake device on the two ends of an in-memory pair.
struct Link {
  explicit Link(boost::asio::any_io_executor executor, const Options& options = short_timing()) {
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

  std::shared_ptr<FakeDevice> device;
  std::optional<Client> client;
};

/// The request frame a client writes for `payload` with `id`.
inline std::string request_frame(const std::string& payload, std::uint8_t id) {
  std::uint8_t buffer[128];
  const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()), id, buffer);
  return std::string(reinterpret_cast<const char*>(buffer), size.ok() ? size.value() : 0);
}

/// A script answering every good request with `body` (its opcode and id mirrored).
inline FakeDevice::Script answer_with(std::string body) {
  return [body = std::move(body)](const DeviceRequest& request, FakeDevice& device) {
    if (request.error != ErrorCode::no_error) return;
    device.send(FakeDevice::response(request.opcode, body, request.manual ? 0 : request.id));
  };
}

/// Milliseconds since `start`.
inline long long elapsed_ms(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace tether::romi::testing
