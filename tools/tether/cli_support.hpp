// Small helpers shared by the subcommands: their usage text and error messages, the argument loop,
// stopping on SIGINT/SIGTERM, number parsing, JSON output, timestamps, progress on stderr, and a line
// printer that several threads (the I/O thread's event handlers, the shell) share.
#pragma once

#include <sys/types.h>

#include <boost/asio/buffer.hpp>
#include <boost/system/error_code.hpp>

#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

#include "tether/transports/byte_stream.hpp"

namespace tether::cli {

/// A subcommand's name and usage text, and the messages it ends with: `--help`, usage errors (exit
/// status 2) and other failures (exit status 2).
class CommandText {
 public:
  /// What a usage error shows after the message.
  enum class OnUsageError {
    full_usage,  ///< all of the usage text (short texts)
    synopsis,    ///< its first paragraph and "Run `tether NAME --help` for the details." (long texts)
  };
  /// `tether name`, whose `--help` prints `usage`.
  CommandText(std::string_view name, std::string usage, OnUsageError on_usage_error = OnUsageError::full_usage);
  /// Prints the usage text on stdout; returns 0.
  int help() const;
  /// Prints `tether NAME: message`, a blank line and the usage (or its synopsis) on stderr; returns 2.
  int usage_error(const std::string& message) const;
  /// The usage error of an argument nobody took: `unknown option --x` or `unexpected argument 'x'`.
  int unexpected_argument(std::string_view argument) const;
  /// Prints `tether NAME: message` on stderr; returns 2.
  int fail(const std::string& message) const;

 private:
  std::string name_;
  std::string usage_;
  std::string error_usage_;  // what usage errors show
};

/// Takes one argument, argv[index], of a subcommand (advancing `index` past a value it consumes): nothing to
/// go on, or the exit status that ends the program (a usage error).
using ArgumentHandler = std::function<std::optional<int>(std::string_view argument, int& index)>;

/// Walks argv[1..]: `--help`/`-h` prints the usage (exit status 0); every other argument goes to `handle`.
/// Nothing when all were taken, else the exit status.
std::optional<int> parse_arguments(int argc, char** argv, const CommandText& text, const ArgumentHandler& handle);

/// Calls `handler` on SIGINT and SIGTERM instead of ending the process: the subcommands that run until
/// stopped end cleanly (counters printed, ptys closed).
void handle_stop_signals(void (*handler)(int));

/// `handle_stop_signals` with a handler that sets the returned flag (cleared first), for loops that poll it.
const std::atomic<bool>& catch_stop_signals();

/// Ends the process group that child `pid` leads (spawned with POSIX_SPAWN_SETPGROUP, pgroup 0): SIGTERM,
/// then SIGKILL after `grace` (or at once once `pid` ended, for what it started and left behind); reaps
/// `pid` and returns its wait status. A child that ignores SIGTERM cannot keep a command waiting.
int end_process_group(pid_t pid, std::chrono::milliseconds grace);

/// While alive, a stop signal caught by `catch_stop_signals` runs `action` (once, within ~50 ms, on a watcher
/// thread): closing the device there ends whatever a command is blocked on (a write to a device that does
/// not read, a call waiting for its budget), so Ctrl-C ends every command within a second. Destroyed before
/// what `action` touches; the destructor waits for an `action` that is running.
class StopAction {
 public:
  explicit StopAction(std::function<void()> action);
  ~StopAction();
  StopAction(const StopAction&) = delete;
  StopAction& operator=(const StopAction&) = delete;

 private:
  std::uint64_t id_;
};

/// How long one write to a device may block before the device counts as not reading: a full UART or pty
/// buffer drains in far less on any working link (4 KB at 9600 baud: ~4 s is the slowest case we accept).
inline constexpr std::chrono::milliseconds kDeviceWriteTimeout{4000};

/// Writes all of `bytes` to `stream`, giving up at `kDeviceWriteTimeout` from now or at `end`, whichever
/// comes first (`TransportError::timed_out`; the stream is then closed: see `ByteStream::write`).
std::size_t write_to_device(transports::ByteStream& stream, boost::asio::const_buffer bytes,
                            boost::system::error_code& error,
                            std::chrono::steady_clock::time_point end = std::chrono::steady_clock::time_point::max());

/// Makes `link` point to `target` (a pty's `--link PATH`). An existing symlink is taken to be stale and
/// replaced; anything else at that path is left alone and reported (`message`, and the error).
std::error_code make_link(const std::filesystem::path& link, const std::string& target, std::string& message);
/// Removes `link` if it still points to `target` (someone may have replaced it meanwhile).
void remove_link(const std::filesystem::path& link, const std::string& target);

/// Parses a decimal number in [minimum, maximum]; nothing when malformed or out of range.
std::optional<std::uint32_t> parse_number(std::string_view text, std::uint32_t minimum, std::uint32_t maximum);
/// Parses a signed decimal number in [minimum, maximum].
std::optional<std::int64_t> parse_signed(std::string_view text, std::int64_t minimum, std::int64_t maximum);
/// Parses seconds (`10`, `0.5`) in [0, maximum] into milliseconds.
std::optional<std::uint32_t> parse_seconds(std::string_view text, double maximum);

/// Compact one-line JSON; invalid UTF-8 is replaced, never thrown.
std::string dump(const nlohmann::ordered_json& value);

/// True when stderr is a terminal (progress is shown only then).
bool stderr_is_terminal();

/// A status line on stderr, rewritten in place, shown only when stderr is a terminal; cleared by `clear()`
/// and on destruction. While it is shown, a SIGINT or SIGTERM that would kill the process (no handler of
/// the command's) erases it first, so the shell's prompt does not land behind it. Not thread-safe (the
/// thread running the subcommand owns it).
class Progress {
 public:
  /// Progress of `tether <command>`.
  explicit Progress(std::string_view command);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  /// Shows `text` (replacing what was shown).
  void show(const std::string& text);
  /// Removes the line.
  void clear();

 private:
  std::string command_;
  bool enabled_;
  bool shown_ = false;
};

/// Timestamps of one run: milliseconds since `start`, or the wall clock in ISO 8601 UTC.
class Timestamps {
 public:
  /// Relative to now; `utc` selects ISO 8601 wall-clock stamps instead.
  explicit Timestamps(bool utc);
  /// `12.345` (ms since the start, 3 decimals) or `2024-05-01T12:00:00.123Z`.
  std::string text() const;
  /// Adds the stamp to a JSON object: `"t_ms": 12.345` or `"time": "2024-...Z"`.
  void add_to(nlohmann::ordered_json& object) const;

 private:
  bool utc_;
  std::chrono::steady_clock::time_point start_;
};

/// Writes whole lines to stdout under one lock and flushes each, so lines from the I/O thread (events) and
/// from the main thread never interleave. The shell's line editor takes the lines over while it edits (it
/// prints them above the line being edited).
///
/// A reader that stops reading (a full pipe) must not keep the command from ending: while stdout takes no
/// bytes the printer looks every 100 ms at a stop signal (`catch_stop_signals`) and at `set_give_up`'s
/// condition; once either holds, that line and every later one are dropped and `write_failure()` says so.
class LinePrinter {
 public:
  /// Prints `line` + '\n' and flushes (or hands `line` to the output handler).
  void line(const std::string& text);
  /// Prints `text` as is (no newline) and flushes.
  void raw(const std::string& text);
  /// Hands every line (without its newline) to `handler` instead of printing it; called under the printer's
  /// lock, so it must not print. An empty function prints directly again.
  void set_output_handler(std::function<void(const std::string&)> handler);
  /// Also gives up waiting for a blocked stdout when `give_up()` returns true (e.g. `--duration` is up);
  /// called from the printing thread while it waits. An empty function: only on a stop signal.
  void set_give_up(std::function<bool()> give_up);
  /// Flushes what stdio holds for stdout (printf's output), keeping why it failed for `write_failure()`:
  /// the flush's errno is gone by the time the command exits.
  void flush();
  /// Why the output did not all reach stdout (empty: it did), for the exit's message.
  std::string write_failure();

 private:
  void write_locked(std::string_view bytes);
  bool flush_locked();

  std::mutex mutex_;
  std::function<void(const std::string&)> handler_;
  std::function<bool()> give_up_;
  std::string write_failure_;
};

/// The process's stdout printer.
LinePrinter& out();

/// Text a device sent, safe to print on a terminal: C0 control bytes (NUL, ESC, BEL, CR, LF, ...), DEL,
/// C1 controls (U+0080..U+009F) and bytes that are not UTF-8 become `\xNN` (one per byte); valid UTF-8
/// otherwise passes unchanged. Every human-readable line that carries device text goes through it (JSON
/// output escapes on its own).
std::string printable(std::string_view bytes);

}  // namespace tether::cli
