// Running the real `tether` program in tests: as a command whose stdout, stderr and exit status are
// collected, as `tether sim` serving a pty, and on a terminal (a new pty as its stdin, stdout and stderr, its
// controlling terminal) typed into the way a person would.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "tether/testing/child_process.hpp"

#ifndef TETHER_BINARY
#error "TETHER_BINARY must name the built tether program"
#endif
#ifndef TETHER_FIRMWARE_DIR
#error "TETHER_FIRMWARE_DIR must name the build's firmware folder"
#endif

namespace tether::cli::testing {

/// What a finished run produced.
struct Outcome {
  int status = -1000;  ///< exit status (-1000: it did not finish within the hang limit)
  std::string out;     ///< stdout
  std::string err;     ///< stderr
  /// stdout split into lines (without '\n').
  std::vector<std::string> lines() const;
};

/// True when all of `text` matches `pattern`: `#` stands for one or more digits, `~` for one or more spaces,
/// `*` for any characters (none included); everything else is literal. (std::regex is avoided: GCC 12
/// warns inside it under the sanitizers.)
bool matches(std::string_view text, std::string_view pattern);

/// Runs `tether ARGS...` to completion (hang protection: 60 s), stdin from /dev/null; `environment`
/// (`NAME=VALUE` entries) is added to its environment.
Outcome run_tether(const std::vector<std::string>& arguments, const std::vector<std::string>& environment = {});
/// `run_tether` of another build of the command (`binary`: a test build with codecs of its own).
Outcome run_program(const std::string& binary, const std::vector<std::string>& arguments,
                    const std::vector<std::string>& environment = {});

/// `build/firmware/<name>.elf`.
std::filesystem::path firmware(const std::string& name);

/// Skips the test when the AVR image is not built (a host-only build).
#define TETHER_REQUIRE_FIRMWARE(name)                                                               \
  do {                                                                                              \
    if (!std::filesystem::exists(::tether::cli::testing::firmware(name))) {                         \
      GTEST_SKIP() << ::tether::cli::testing::firmware(name) << " is not built (TETHER_BUILD_AVR)"; \
    }                                                                                               \
  } while (false)

/// `tether sim IMAGE` in the background; `pty()` is the port it serves.
class SimBoard {
 public:
  explicit SimBoard(const std::string& image);
  /// `tether sim ARGUMENTS...` (e.g. `--bootloader`).
  explicit SimBoard(const std::vector<std::string>& arguments);
  const std::string& pty() const { return pty_; }

 private:
  ::tether::testing::ChildProcess process_;
  std::string pty_;
};

/// `tether ARGS...` on a new pseudo-terminal: the pty's slave is its controlling terminal, stdin, stdout
/// and stderr, in the terminal's default (canonical, echoing) mode. The test types on the master side
/// and reads the screen from it.
class Terminal {
 public:
  explicit Terminal(const std::vector<std::string>& arguments) : Terminal(TETHER_BINARY, arguments) {}
  /// `program ARGS...` on the terminal (a test build of the command, say).
  Terminal(const std::string& program, const std::vector<std::string>& arguments);
  ~Terminal();
  Terminal(const Terminal&) = delete;
  Terminal& operator=(const Terminal&) = delete;

  /// Types `text` (use "\n" for Enter, "\x04" for Ctrl-D at the start of a line).
  void type(std::string_view text);
  /// Waits until `text` appears on the screen after the previous match; moves past it. False after
  /// `timeout` (hang protection) or when the program ended without printing it.
  bool expect(std::string_view text, std::chrono::milliseconds timeout = std::chrono::seconds(20));
  /// Everything printed so far.
  std::string screen() const;
  /// Waits for the exit; the exit status, nothing after `timeout`. Once it has one, `screen()` holds
  /// everything the program printed (the reader has seen the terminal close).
  std::optional<int> wait_exit(std::chrono::milliseconds timeout = std::chrono::seconds(20));

 private:
  void read_loop();

  int master_ = -1;
  pid_t pid_ = -1;
  std::optional<int> status_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::string screen_;
  std::size_t cursor_ = 0;
  bool closed_ = false;
  bool stop_ = false;
  std::thread reader_;
};

#ifdef TETHER_SOURCE_DIR
/// The virtual rover of docs/examples/rover-virtual.json: a device of every codec on simulated Unos.
inline const std::string kRover = std::string(TETHER_SOURCE_DIR) + "/docs/examples/rover-virtual.json";
#endif

}  // namespace tether::cli::testing
