/// @file fuzz_link.hpp
/// The device end of a host client under a fuzzer: the client gets one end of an in-memory stream pair,
/// the target plays the device on the other. An I/O thread runs the executor for the whole input (the
/// clients' blocking parts, e.g. `close()`, need one), the target writes what the "device" says with
/// `deliver`, and everything the client writes is read at once and handed to `on_written` (on the I/O
/// thread), so a target can decode requests and answer them. Header-only: only targets that link the
/// transports include it.
#pragma once

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>

#include "tether/testing/fuzz_target.hpp"
#include "tether/transports/in_memory_stream.hpp"

namespace tether::testing {

/// See the file overview.
class FuzzLink {
 public:
  /// What the client wrote, in order (I/O thread).
  using WrittenHandler = std::function<void(const std::uint8_t* data, std::size_t size)>;

  explicit FuzzLink(WrittenHandler on_written) : on_written_(std::move(on_written)) {
    auto [host, device] = transports::InMemoryStream::make_pair(io_.get_executor(), 1u << 16);
    host_ = std::move(host);
    device_ = std::move(device);
    read_next();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~FuzzLink() {
    device_->close();
    work_.reset();
    io_.stop();
    thread_.join();
  }
  FuzzLink(const FuzzLink&) = delete;
  FuzzLink& operator=(const FuzzLink&) = delete;

  /// The client's end.
  std::shared_ptr<transports::ByteStream> host_end() const { return host_; }
  /// The executor (for the client's completions).
  boost::asio::io_context& io() { return io_; }
  /// Writes `size` bytes as the device; blocks until the pair took them (bounded: the client reads on).
  void deliver(const std::uint8_t* data, std::size_t size) {
    boost::system::error_code error;
    device_->write(boost::asio::buffer(data, size), std::chrono::steady_clock::now() + std::chrono::seconds(10), error);
    TETHER_FUZZ_CHECK(!error || !host_->is_open());  // a client that stops reading is a finding
  }

 private:
  void read_next() {
    device_->async_read_some(boost::asio::buffer(buffer_), [this](boost::system::error_code error, std::size_t size) {
      if (size > 0) on_written_(buffer_.data(), size);
      if (!error) read_next();
    });
  }

  WrittenHandler on_written_;
  boost::asio::io_context io_;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> work_ = boost::asio::make_work_guard(io_);
  std::shared_ptr<transports::InMemoryStream> host_;
  std::shared_ptr<transports::InMemoryStream> device_;
  std::array<std::uint8_t, 512> buffer_{};
  std::thread thread_;
};

/// Replays a stateful target's input after its first byte (the target's options): bytes go to the client in
/// runs as the device's output; `0xFF CMD` (not as the last byte) delivers the run so far, then calls
/// `on_command(CMD, i)` where `i` indexes CMD in `data`; it returns how many bytes after CMD it consumed.
template <typename OnCommand>
void replay_input(FuzzLink& link, const std::uint8_t* data, std::size_t size, OnCommand on_command) {
  std::size_t run_start = 1;
  const auto flush = [&](std::size_t end) {
    if (end > run_start) link.deliver(data + run_start, end - run_start);
  };
  for (std::size_t i = 1; i < size; ++i) {
    if (data[i] != 0xFF || i + 1 >= size) continue;
    flush(i);
    ++i;
    i += on_command(data[i], i);
    run_start = i + 1;
  }
  flush(size);
}

/// Waits until `done()` (polled every 50 us: the I/O thread usually needs microseconds) for at most
/// `limit`; false when it never held.
template <typename Predicate>
bool wait_for_fuzz(Predicate done, std::chrono::milliseconds limit = std::chrono::seconds(10)) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  return true;
}

/// Waits until everything posted to `executor` before this call ran: a round trip through the client's strand,
/// so all the bytes delivered before were handled.
template <typename Executor>
void catch_up(const Executor& executor) {
  std::atomic<bool> caught_up{false};
  boost::asio::post(executor, [&caught_up] { caught_up = true; });
  TETHER_FUZZ_CHECK(wait_for_fuzz([&] { return caught_up.load(); }));
}

}  // namespace tether::testing
