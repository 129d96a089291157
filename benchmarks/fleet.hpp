// The fleet benchmarks' harness (benchmarks/fleet_benchmark.cpp, and a codec's own, such as
// codecs/rpc/benchmarks/fleet_benchmark.cpp): the host thread's CPU and context switches, a fake device's
// byte loop on the device thread, a caller that starts one call per period unless the last is in flight,
// and the latency tally with its percentiles.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tether/transports/byte_stream.hpp"

namespace tether::fleet {

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

// CPU time of the calling thread.
inline std::chrono::nanoseconds thread_cpu() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return std::chrono::seconds(now.tv_sec) + std::chrono::nanoseconds(now.tv_nsec);
}

// The calling thread's user and system CPU and its context switches (getrusage).
struct ThreadUsage {
  double user_us = 0;
  double system_us = 0;
  long voluntary_switches = 0;
  long involuntary_switches = 0;

  static ThreadUsage now() {
    rusage usage{};
    getrusage(RUSAGE_THREAD, &usage);
    const auto us = [](const timeval& t) { return static_cast<double>(t.tv_sec) * 1e6 + static_cast<double>(t.tv_usec); };
    return {us(usage.ru_utime), us(usage.ru_stime), usage.ru_nvcsw, usage.ru_nivcsw};
  }
  ThreadUsage operator-(const ThreadUsage& start) const {
    return {user_us - start.user_us, system_us - start.system_us, voluntary_switches - start.voluntary_switches,
            involuntary_switches - start.involuntary_switches};
  }
};

// --- fake devices (device thread) ----------------------------------------------------------------------

// A device end: reads continuously, hands bytes to `on_bytes`, writes answers in order.
class FakeDevice : public std::enable_shared_from_this<FakeDevice> {
 public:
  explicit FakeDevice(std::shared_ptr<transports::ByteStream> end) : end_(std::move(end)) {}
  virtual ~FakeDevice() = default;

  void start() { read(); }
  void close() {
    asio::post(end_->get_executor(), [self = shared_from_this()] { self->end_->close(); });
  }

 protected:
  virtual void on_bytes(const std::uint8_t* data, std::size_t size) = 0;

  void send(const std::uint8_t* data, std::size_t size) {
    outbox_.emplace_back(reinterpret_cast<const char*>(data), size);
    if (outbox_.size() == 1) write_front();
  }

 private:
  void read() {
    end_->async_read_some(asio::buffer(input_), [self = shared_from_this()](error_code error, std::size_t size) {
      if (error) return;
      self->on_bytes(self->input_.data(), size);
      self->read();
    });
  }
  void write_front() {
    asio::async_write(*end_, asio::buffer(outbox_.front()), [self = shared_from_this()](error_code error, std::size_t) {
      if (error) return;
      self->outbox_.pop_front();
      if (!self->outbox_.empty()) self->write_front();
    });
  }

  std::shared_ptr<transports::ByteStream> end_;
  std::array<std::uint8_t, 512> input_{};
  std::deque<std::string> outbox_;
};

// --- host side (host thread) ----------------------------------------------------------------------------

struct Tally {
  std::vector<double> latencies_us;
  std::uint64_t calls = 0;
  std::uint64_t errors = 0;
  std::uint64_t skipped = 0;
};

// One device's caller: a tick every period starts a call unless the previous one is still in flight.
class Caller {
 public:
  using Start = std::function<void(std::function<void(bool ok)>)>;

  Caller(asio::io_context& io, Clock::duration period, Start start, Tally& tally)
      : timer_(io), period_(period), start_(std::move(start)), tally_(tally) {}

  void run(Clock::time_point first, Clock::time_point end) {
    next_ = first;
    end_ = end;
    tick();
  }

 private:
  void tick() {
    if (next_ >= end_) return;
    timer_.expires_at(next_);
    timer_.async_wait([this](error_code error) {
      if (error) return;
      next_ += period_;
      if (busy_) {
        ++tally_.skipped;
      } else {
        busy_ = true;
        const Clock::time_point started = Clock::now();
        start_([this, started](bool ok) {
          busy_ = false;
          tally_.latencies_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - started).count());
          ++tally_.calls;
          if (!ok) ++tally_.errors;
        });
      }
      tick();
    });
  }

  asio::steady_timer timer_;
  Clock::duration period_;
  Start start_;
  Tally& tally_;
  Clock::time_point next_;
  Clock::time_point end_;
  bool busy_ = false;
};

inline double percentile(std::vector<double> sorted, double fraction) {
  if (sorted.empty()) return 0;
  const auto index = static_cast<std::size_t>(fraction * static_cast<double>(sorted.size() - 1) + 0.5);
  return sorted[std::min(index, sorted.size() - 1)];
}

inline void print(const char* name, const Tally& tally) {
  std::vector<double> sorted = tally.latencies_us;
  std::sort(sorted.begin(), sorted.end());
  std::printf("  %-8s calls %7llu  errors %llu  skipped %llu  latency us: p50 %7.1f  p90 %7.1f  p99 %7.1f  max %8.1f\n",
              name, static_cast<unsigned long long>(tally.calls), static_cast<unsigned long long>(tally.errors),
              static_cast<unsigned long long>(tally.skipped), percentile(sorted, 0.50), percentile(sorted, 0.90),
              percentile(sorted, 0.99), sorted.empty() ? 0.0 : sorted.back());
}


/// What a fleet run measured: the host thread's CPU and usage over the measured part (its `seconds` and the
/// 3 s after them in which the last calls complete), and the device thread's CPU over the whole run.
struct FleetRun {
  std::chrono::nanoseconds host_cpu{0};
  ThreadUsage host_usage;
  std::chrono::nanoseconds device_cpu{0};
};

/// Runs a fleet: `device_io` on a thread of its own, `host_io` on another; after a warm-up second (sessions
/// open, first allocations) the callers start, spread over one `period`, and tick for `seconds`; 3 s later
/// `close` runs on the host thread (close the clients and the devices' ends), and both io_contexts finish.
inline FleetRun run_fleet(asio::io_context& host_io, asio::io_context& device_io,
                          std::vector<std::unique_ptr<Caller>>& callers, Clock::duration period, double seconds,
                          const std::function<void()>& at_start, const std::function<void()>& close) {
  auto host_work = asio::make_work_guard(host_io);
  auto device_work = asio::make_work_guard(device_io);
  FleetRun result;
  std::thread device_thread([&] { device_io.run(); });
  std::promise<void> measured;
  ThreadUsage usage_at_start;
  std::chrono::nanoseconds cpu_at_start{0};
  const Clock::time_point start = Clock::now() + std::chrono::seconds(1);
  const auto duration = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  asio::steady_timer begin(host_io);
  begin.expires_at(start);
  begin.async_wait([&](error_code) {
    if (at_start) at_start();
    cpu_at_start = thread_cpu();
    usage_at_start = ThreadUsage::now();
    for (std::size_t i = 0; i < callers.size(); ++i) {
      callers[i]->run(start + period * static_cast<int>(i) / static_cast<int>(callers.size()), start + duration);
    }
  });
  asio::steady_timer finish(host_io);
  finish.expires_at(start + duration + std::chrono::seconds(3));  // the last calls complete
  finish.async_wait([&](error_code) {
    result.host_usage = ThreadUsage::now() - usage_at_start;
    result.host_cpu = thread_cpu() - cpu_at_start;
    measured.set_value();
    close();
    asio::post(device_io, [&] { result.device_cpu = thread_cpu(); });
    host_work.reset();
    device_work.reset();
  });
  std::thread host_thread([&] { host_io.run(); });
  measured.get_future().wait();
  host_thread.join();
  device_thread.join();
  return result;
}

/// Prints the host thread's CPU per call and its getrusage split, and the device thread's CPU.
inline void print_cpu(const FleetRun& run, std::uint64_t calls, double seconds) {
  const double host = static_cast<double>(run.host_cpu.count());
  std::printf("  host thread CPU: %.1f ms for %llu calls = %.2f us per call (%.1f %% of one core)\n", host / 1e6,
              static_cast<unsigned long long>(calls), calls ? host / 1e3 / static_cast<double>(calls) : 0.0,
              100.0 * host / 1e9 / (seconds + 3));
  const double per_call = calls ? 1.0 / static_cast<double>(calls) : 0.0;
  std::printf("  per call (getrusage): user %.2f us, system %.2f us, %.2f voluntary + %.2f involuntary context switches\n",
              run.host_usage.user_us * per_call, run.host_usage.system_us * per_call,
              static_cast<double>(run.host_usage.voluntary_switches) * per_call,
              static_cast<double>(run.host_usage.involuntary_switches) * per_call);
  std::printf("  device thread CPU (fake devices, whole run): %.1f ms\n", static_cast<double>(run.device_cpu.count()) / 1e6);
}

}  // namespace tether::fleet
