// Helpers for the virtual Uno tests: firmware paths, output recorders, a pty client and a child process.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <sys/types.h>
#include <vector>

#include "tether/transports/virtual_uno.hpp"

namespace tether::transports::test {

using namespace std::chrono_literals;

/// What build/firmware/echo.elf prints at boot.
inline constexpr std::string_view kEchoBanner = "tether echo\r\n";

/// `${TETHER_FIRMWARE_DIR}/<name>`.
std::filesystem::path firmware_path(std::string_view name);

/// Options for the echo image, fast pacing, seeded from RANDOM_SEED (mixed with `stream`).
VirtualUnoOptions echo_options(std::uint64_t stream = 0);

std::size_t count_occurrences(std::string_view text, std::string_view needle);

/// Records everything a board sends to the host through its output handler, with the simulated cycle
/// at which each batch arrived. Clears the handler when destroyed.
class OutputRecorder {
 public:
  explicit OutputRecorder(VirtualUno& uno);
  ~OutputRecorder();
  OutputRecorder(const OutputRecorder&) = delete;
  OutputRecorder& operator=(const OutputRecorder&) = delete;

  struct Batch {
    std::string bytes;
    std::uint64_t cycle;
  };
  std::string text() const;
  std::vector<Batch> batches() const;
  /// Cycle at which byte `index` (0-based, over the whole recording) arrived.
  std::uint64_t cycle_of(std::size_t index) const;
  void clear();
  /// Waits (wall time) until `needle` occurs `count` times (for boards running on a thread).
  bool wait_for(std::string_view needle, std::chrono::milliseconds timeout, std::size_t count = 1);
  bool wait_for_size(std::size_t size, std::chrono::milliseconds timeout);

 private:
  VirtualUno& uno_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Batch> batches_;
  std::string text_;
};

/// Advances `advance(step)` until `done()` or `limit` of simulated time has passed. Returns done().
bool run_until(const std::function<void(SimDuration)>& advance, const std::function<bool()>& done,
               SimDuration limit, SimDuration step = 1ms);

/// Reads VirtualUno::read() until `needle` appears; returns everything read.
std::string read_until(VirtualUno& uno, std::string_view needle, std::chrono::milliseconds timeout);

/// A serial program on the other end of a pty: opens the slave path raw-as-is, reads with a deadline.
class PtyClient {
 public:
  explicit PtyClient(const std::string& path);
  ~PtyClient();
  PtyClient(const PtyClient&) = delete;
  PtyClient& operator=(const PtyClient&) = delete;
  bool is_open() const { return fd_ >= 0; }
  void write(std::string_view text);
  /// Reads until `needle` is among the bytes read so far (or timeout); returns them all.
  std::string read_until(std::string_view needle, std::chrono::milliseconds timeout);
  /// True once the other end (the master) has gone: a read returns end-of-file or EIO.
  bool hung_up(std::chrono::milliseconds timeout);

 private:
  int fd_ = -1;
  std::string pending_;
};

/// A child process with stdout and stderr on pipes. The destructor kills (SIGKILL) and reaps it if it
/// still runs, and closes the pipes: nothing leaks even when a test fails half-way.
class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// Next line of stdout (without '\n'), or nullopt at EOF/timeout.
  std::optional<std::string> read_line(std::chrono::milliseconds timeout);
  void signal(int number);
  /// Exit status (or 128 + signal), nullopt on timeout.
  std::optional<int> wait(std::chrono::milliseconds timeout);
  /// What the child wrote to stderr so far (after wait(): everything).
  std::string error_output();

 private:
  void drain_stderr(bool block);
  pid_t pid_ = -1;
  int out_ = -1;
  int err_ = -1;
  std::string out_buffer_;
  std::string err_buffer_;
  std::optional<int> status_;
};

}  // namespace tether::transports::test
