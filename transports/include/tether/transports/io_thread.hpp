/// @file io_thread.hpp
/// An asio io_context run by one background thread for the lifetime of the object. The blocking calls of
/// streams and clients (`read_some`, `romi::Client::call`, ...) need some other thread to run the executor:
/// programs without an event loop of their own create one of these and pass `executor()` to the streams.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>

#include <thread>
#include <vector>

namespace tether::transports {

/// io_context + work guard + thread(s); stops and joins on destruction.
class IoThread {
 public:
  /// One thread; `threads` > 1 runs the context on that many (tests check that a client's strand
  /// serialises it across them).
  explicit IoThread(unsigned threads = 1) : guard_(boost::asio::make_work_guard(io_)) {
    for (unsigned i = 0; i < threads; ++i) threads_.emplace_back([this] { io_.run(); });
  }
  ~IoThread() {
    guard_.reset();
    io_.stop();
    for (auto& thread : threads_) thread.join();
  }
  IoThread(const IoThread&) = delete;
  IoThread& operator=(const IoThread&) = delete;

  /// Executor for streams and timers.
  boost::asio::any_io_executor executor() { return io_.get_executor(); }

 private:
  boost::asio::io_context io_;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> guard_;
  std::vector<std::thread> threads_;
};

}  // namespace tether::transports
