/// @file child_process.hpp
/// A child process for tests (socat, ser2net, `tether sim`): started with posix_spawnp, stdout captured
/// line by line, and always stopped (SIGTERM, then SIGKILL) and reaped when the object goes away, so no
/// test leaks a process.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "tether/testing/eventually.hpp"  // NOLINT(misc-include-cleaner): users of child processes wait with it

namespace tether::testing {

/// Running child process.
class ChildProcess {
 public:
  /// Starts `argv[0]` (searched in PATH) with `argv`. stdout is captured when `capture_stdout`, stderr
  /// goes to /dev/null unless `show_stderr`. Throws std::system_error when it cannot start.
  explicit ChildProcess(const std::vector<std::string>& argv, bool capture_stdout = false, bool show_stderr = false);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// Next line of stdout (without '\n'), or nothing at EOF or after `timeout`.
  std::optional<std::string> read_line(std::chrono::milliseconds timeout);
  /// Sends `signal`.
  void signal(int signal_number);
  /// Waits up to `timeout` until the process catches `signal_number` (a handler installed, per
  /// /proc/<pid>/status): a signal sent before that would find the default action, not the program's.
  bool wait_until_catching(int signal_number, std::chrono::milliseconds timeout);
  /// Waits up to `timeout` for the exit; the exit status (or -signal), nothing on timeout.
  std::optional<int> wait(std::chrono::milliseconds timeout);
  /// Process id.
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string pending_;
  std::optional<int> status_;
};

}  // namespace tether::testing
