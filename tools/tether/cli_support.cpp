// Helpers shared by the subcommands (see cli_support.hpp).
#include "cli_support.hpp"

#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <thread>
#include <utility>

#include "tether/core/utf8.hpp"

namespace tether::cli {

CommandText::CommandText(std::string_view name, std::string usage, OnUsageError on_usage_error)
    : name_(name), usage_(std::move(usage)) {
  error_usage_ =
      on_usage_error == OnUsageError::full_usage
          ? usage_
          : usage_.substr(0, usage_.find("\n\n") + 1) + "Run `tether " + name_ + " --help` for the details.\n";
}

int CommandText::help() const {
  std::fputs(usage_.c_str(), stdout);
  return 0;
}

int CommandText::usage_error(const std::string& message) const {
  std::fprintf(stderr, "tether %s: %s\n\n%s", name_.c_str(), message.c_str(), error_usage_.c_str());
  return 2;
}

int CommandText::unexpected_argument(std::string_view argument) const {
  return usage_error(argument.starts_with("-") ? "unknown option " + std::string(argument)
                                               : "unexpected argument '" + std::string(argument) + "'");
}

int CommandText::fail(const std::string& message) const {
  std::fprintf(stderr, "tether %s: %s\n", name_.c_str(), message.c_str());
  return 2;
}

std::optional<int> parse_arguments(int argc, char** argv, const CommandText& text, const ArgumentHandler& handle) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view argument = argv[i];
    if (argument == "--help" || argument == "-h") return text.help();
    if (const auto status = handle(argument, i)) return status;
  }
  return std::nullopt;
}

void handle_stop_signals(void (*handler)(int)) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

namespace {

std::atomic<bool> g_stop_requested{false};

void request_stop(int) { g_stop_requested = true; }

}  // namespace

namespace {

// The StopActions alive and the thread that runs them on a stop signal. Never destroyed: the watcher may
// still look at it while the process exits.
struct StopWatcher {
  std::mutex mutex;
  std::map<std::uint64_t, std::function<void()>> actions;
  std::uint64_t next_id = 1;
  bool started = false;

  static StopWatcher& instance() {
    static auto* watcher = new StopWatcher;
    return *watcher;
  }
  // Polls the flag (a signal handler can only set it); runs each action once, under the lock, so that a
  // StopAction's destructor waits for its action.
  void start() {
    if (started) return;
    started = true;
    std::thread([this] {
      for (;;) {
        std::this_thread::sleep_for(std::chrono::milliseconds(25));
        if (!g_stop_requested) continue;
        const std::lock_guard lock(mutex);
        for (auto& [id, action] : actions) {
          if (action) std::exchange(action, nullptr)();
        }
      }
    }).detach();
  }
};

}  // namespace

int end_process_group(pid_t pid, std::chrono::milliseconds grace) {
  ::kill(-pid, SIGTERM);
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + grace;
  while (std::chrono::steady_clock::now() < deadline) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid || (done < 0 && errno != EINTR)) {
      ::kill(-pid, SIGKILL);  // what it started and left behind
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(-pid, SIGKILL);
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

const std::atomic<bool>& catch_stop_signals() {
  g_stop_requested = false;
  handle_stop_signals(request_stop);
  return g_stop_requested;
}

StopAction::StopAction(std::function<void()> action) {
  StopWatcher& watcher = StopWatcher::instance();
  const std::lock_guard lock(watcher.mutex);
  id_ = watcher.next_id++;
  watcher.actions.emplace(id_, std::move(action));
  watcher.start();
}

StopAction::~StopAction() {
  StopWatcher& watcher = StopWatcher::instance();
  const std::lock_guard lock(watcher.mutex);
  watcher.actions.erase(id_);
}

std::size_t write_to_device(transports::ByteStream& stream, boost::asio::const_buffer bytes,
                            boost::system::error_code& error, std::chrono::steady_clock::time_point end) {
  const auto deadline = std::min(end, std::chrono::steady_clock::now() + kDeviceWriteTimeout);
  return stream.write(bytes, deadline, error);
}

std::optional<std::uint32_t> parse_number(std::string_view text, std::uint32_t minimum, std::uint32_t maximum) {
  std::uint32_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < minimum || value > maximum) {
    return std::nullopt;
  }
  return value;
}

std::optional<std::int64_t> parse_signed(std::string_view text, std::int64_t minimum, std::int64_t maximum) {
  if (text.starts_with('+')) text.remove_prefix(1);
  std::int64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || value < minimum || value > maximum) {
    return std::nullopt;
  }
  return value;
}

std::optional<std::uint32_t> parse_seconds(std::string_view text, double maximum) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value) || value < 0 ||
      value > maximum) {
    return std::nullopt;
  }
  return static_cast<std::uint32_t>(std::llround(value * 1000.0));
}

std::string dump(const nlohmann::ordered_json& value) {
  return value.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

namespace {

constexpr char kEraseLine[] = "\r\033[K";

// Puts `signal_number` back to its default action (async-signal-safe).
void restore_default_action(int signal_number) {
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  sigemptyset(&default_action.sa_mask);
  ::sigaction(signal_number, &default_action, nullptr);
}

// A progress line being written, and a stop signal on its way: the handler may run on another thread than
// the one writing, so it waits for a write in flight to end (bounded: the writer may be the thread it
// interrupted) and a write that sees the stop does not start; else a line written after the erasure stays on
// the terminal. Lock-free atomics: safe in a signal handler.
std::atomic<int> g_progress_writers{0};
std::atomic<bool> g_progress_stopping{false};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free);

// A stop signal's default action, after erasing the progress line (async-signal-safe calls only).
void erase_progress_and_die(int signal_number) {
  g_progress_stopping.store(true);
  const struct timespec step = {0, 1000000};  // 1 ms, up to 500 ms
  for (int waited = 0; waited < 500 && g_progress_writers.load() > 0; ++waited) ::nanosleep(&step, nullptr);
  (void)!::write(STDERR_FILENO, kEraseLine, sizeof kEraseLine - 1);
  restore_default_action(signal_number);
  ::raise(signal_number);
}

// Installs `erase_progress_and_die` for the stop signals left at their default; undone by `disarm`.
void arm_progress_erasure() {
  for (const int signal_number : {SIGINT, SIGTERM}) {
    struct sigaction current {};
    if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler != SIG_DFL) continue;
    struct sigaction erase {};
    erase.sa_handler = erase_progress_and_die;
    sigemptyset(&erase.sa_mask);
    ::sigaction(signal_number, &erase, nullptr);
  }
}

void disarm_progress_erasure() {
  for (const int signal_number : {SIGINT, SIGTERM}) {
    struct sigaction current {};
    if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler != erase_progress_and_die) continue;
    restore_default_action(signal_number);
  }
}

}  // namespace

Progress::Progress(std::string_view command) : command_(command), enabled_(stderr_is_terminal()) {}

Progress::~Progress() { clear(); }

void Progress::show(const std::string& text) {
  if (!enabled_) return;
  if (!shown_) arm_progress_erasure();
  g_progress_writers.fetch_add(1);
  if (!g_progress_stopping.load()) {
    std::fprintf(stderr, "\r\033[Ktether %s: %s", command_.c_str(), text.c_str());
    std::fflush(stderr);
  }
  g_progress_writers.fetch_sub(1);
  shown_ = true;
}

void Progress::clear() {
  if (!shown_) return;
  disarm_progress_erasure();
  std::fputs(kEraseLine, stderr);
  std::fflush(stderr);
  shown_ = false;
}

Timestamps::Timestamps(bool utc) : utc_(utc), start_(std::chrono::steady_clock::now()) {}

std::string Timestamps::text() const {
  char buffer[64];
  if (utc_) {
    const auto now = std::chrono::system_clock::now();
    const auto since_epoch = now.time_since_epoch();
    const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since_epoch);
    const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(since_epoch - seconds).count();
    const std::time_t time = static_cast<std::time_t>(seconds.count());
    std::tm parts{};
    gmtime_r(&time, &parts);
    const std::size_t length = std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%S", &parts);
    std::snprintf(buffer + length, sizeof buffer - length, ".%03dZ", static_cast<int>(millis));
    return buffer;
  }
  const auto elapsed = std::chrono::steady_clock::now() - start_;
  const double ms = std::chrono::duration<double, std::milli>(elapsed).count();
  std::snprintf(buffer, sizeof buffer, "%.3f", ms);
  return buffer;
}

void Timestamps::add_to(nlohmann::ordered_json& object) const {
  if (utc_) {
    object["time"] = text();
  } else {
    const auto elapsed = std::chrono::steady_clock::now() - start_;
    const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(elapsed).count();
    object["t_ms"] = static_cast<double>(micros) / 1000.0;
  }
}

void LinePrinter::line(const std::string& text) {
  const std::lock_guard lock(mutex_);
  if (handler_) {
    handler_(text);
    return;
  }
  write_locked(text + '\n');
}

void LinePrinter::raw(const std::string& text) {
  const std::lock_guard lock(mutex_);
  write_locked(text);
}

// Straight to the descriptor, so a full pipe is waited for with poll (which can give up) rather than
// inside a blocking write; what stdio holds from other writers goes first, to keep the order.
void LinePrinter::write_locked(std::string_view bytes) {
  if (!flush_locked()) return;
  while (!bytes.empty()) {
    pollfd ready{STDOUT_FILENO, POLLOUT, 0};
    const int polled = ::poll(&ready, 1, 100);
    if (polled < 0 && errno != EINTR) {
      write_failure_ = std::strerror(errno);
      return;
    }
    if (polled <= 0) {
      if (g_stop_requested || (give_up_ && give_up_())) {
        write_failure_ = "its reader stopped reading";
        return;
      }
      continue;
    }
    // At most PIPE_BUF at once: a pipe that polls writable takes that much without blocking.
    const ssize_t written = ::write(STDOUT_FILENO, bytes.data(), std::min<std::size_t>(bytes.size(), PIPE_BUF));
    if (written < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      write_failure_ = std::strerror(errno);
      return;
    }
    bytes.remove_prefix(static_cast<std::size_t>(written));
  }
}

bool LinePrinter::flush_locked() {
  if (!write_failure_.empty()) return false;
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    write_failure_ = std::strerror(errno != 0 ? errno : EIO);
    return false;
  }
  return true;
}

void LinePrinter::flush() {
  const std::lock_guard lock(mutex_);
  (void)flush_locked();
}

void LinePrinter::set_give_up(std::function<bool()> give_up) {
  const std::lock_guard lock(mutex_);
  give_up_ = std::move(give_up);
}

std::string LinePrinter::write_failure() {
  const std::lock_guard lock(mutex_);
  return write_failure_;
}

void LinePrinter::set_output_handler(std::function<void(const std::string&)> handler) {
  const std::lock_guard lock(mutex_);
  handler_ = std::move(handler);
}

LinePrinter& out() {
  static LinePrinter printer;
  return printer;
}

std::string printable(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text;
  text.reserve(bytes.size());
  const auto escape = [&](unsigned char byte) {
    text += "\\x";
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0x0F];
  };
  const auto* const data = reinterpret_cast<const std::uint8_t*>(bytes.data());
  std::size_t i = 0;
  while (i < bytes.size()) {
    const std::uint8_t lead = data[i];
    if (lead >= 0x20 && lead < 0x7F) {
      text += static_cast<char>(lead);
      ++i;
      continue;
    }
    // Controls are escaped: C0 and DEL (single bytes) and C1 (U+0080..U+009F, C2 80..C2 9F).
    std::size_t length = lead < 0x80 ? 0 : utf8_sequence_length(data, bytes.size(), i);
    if (length == 2 && lead == 0xC2 && data[i + 1] < 0xA0) length = 0;
    if (length == 0) {
      escape(lead);
      ++i;
      continue;
    }
    text.append(bytes.substr(i, length));
    i += length;
  }
  return text;
}

std::error_code make_link(const std::filesystem::path& link, const std::string& target, std::string& message) {
  std::error_code error;
  const auto status = std::filesystem::symlink_status(link, error);
  if (!error && std::filesystem::exists(status)) {
    if (!std::filesystem::is_symlink(status)) {
      message = link.string() + " exists and is not a symlink";
      return std::make_error_code(std::errc::file_exists);
    }
    std::filesystem::remove(link, error);
    if (error) {
      message = "cannot replace " + link.string() + ": " + error.message();
      return error;
    }
  }
  error.clear();
  std::filesystem::create_symlink(target, link, error);
  if (error) message = "cannot create the symlink " + link.string() + ": " + error.message();
  return error;
}

void remove_link(const std::filesystem::path& link, const std::string& target) {
  std::error_code error;
  if (std::filesystem::is_symlink(std::filesystem::symlink_status(link, error)) &&
      std::filesystem::read_symlink(link, error) == target) {
    std::filesystem::remove(link, error);
  }
}

}  // namespace tether::cli
