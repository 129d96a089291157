// `tether shell DEVICE [--json]`: an interactive terminal for a device. Lines typed are sent in the
// device's protocol (romi `s[2,3]`, proxy `servo-control pin=9 position=90`, elcano `D{s 50}{a 25}`), and
// what the device says on its own (romi log lines, proxy events, captured or undeliverable ring messages)
// is printed as it arrives, also while nobody types.
//
// Threads: a reader thread reads stdin and hands lines to the main thread, which runs each line with the
// client's blocking API; the I/O thread runs the client and prints its events. So stdin never blocks the
// asio loop and device events appear while the user is idle. On a terminal the reader edits the line with
// libedit (history, cursor keys) and prints every output line above the line being edited, which it then
// draws again; from a pipe or a file it reads plain lines.
//
// End of input waits (at most RingReplies::kWait) for what Elcano messages sent still owe: the captured
// answer, or the message back undelivered.
//
// Exit status: 0 on `:quit` or end of input (Ctrl-D) or SIGINT/SIGTERM; 2 usage errors, a device that
// cannot be opened, a link that failed (the device went away).
#include <editline/readline.h>
#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "shell_text.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::cli {

namespace {

const CommandText& shell_command() {
  static const CommandText text(
      "shell",
      std::string(
          "usage: tether shell DEVICE [--json]\n"
          "\n"
          "An interactive terminal for a device: type a message, press Enter, read the answer. What the device\n"
          "sends on its own is shown as it arrives, also while you are not typing.\n"
          "  romi          type the command (on romi-test: `e`, `s[2,3]`, `t[\"hi\"]`, `g[2]`); the request id,\n"
          "                CRC and framing are added, the answer array is printed. Log lines (`#!text`) appear\n"
          "                as `log: text`.\n"
          "  proxy         type a message and its fields (`servo-init pin=9 safe-position=90`,\n"
          "                `servo-control pin=9 position=120`; names as in `tether send --help`); the ack is\n"
          "                printed, device errors, pin states, info and session changes appear as they arrive.\n"
          "  elcano        type a message (`D{s 50}{a 25}`, `G{n 1}{p 0,0}{b 90}`); it is sent into the ring.\n"
          "                Captured messages (--capture) and messages that came back undelivered appear as they\n"
          "                arrive; `:capture TYPES` changes the capture set.\n"
          "Shell commands: :help, :stats (the session's counters, as `tether stats` prints them), :quit. End of\n"
          "input (Ctrl-D) quits too. On a terminal the line is edited with libedit: cursor keys, Up/Down for\n"
          "the history, Ctrl-R to search it (~/.editrc applies); what the device says meanwhile is printed\n"
          "above the line being typed. With stdin from a pipe or a file: one message per line; at the end of\n"
          "the input an elcano shell waits up to 3 s for the answers to the messages it sent.\n"
          "\n") +
      device_usage() +
      "\n"
      "  --json         every output line is a JSON object with a \"type\": answer, log, sent, event, stats,\n"
      "                 error, open\n"
      "\n"
      "Exit status: 0 :quit, end of input, SIGINT/SIGTERM; 2 usage errors, a device that cannot be opened,\n"
      "a link that failed.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct ShellArguments {
  DeviceOptions device;
  bool json = false;
};

std::optional<int> parse_shell_arguments(int argc, char** argv, ShellArguments& arguments) {
  const CommandText& text = shell_command();
  const auto own = [&](std::string_view argument, int&) -> std::optional<int> {
    if (argument != "--json") return text.unexpected_argument(argument);
    arguments.json = true;
    return std::nullopt;
  };
  return parse_device_arguments(argc, argv, text, arguments.device, own);
}

// The write end of the pipe that wakes the reader (signals, link failure), and what a signal asked.
std::atomic<int> g_wake_fd{-1};
std::atomic<bool> g_stop_signalled{false};

void on_stop_signal(int) {
  g_stop_signalled = true;
  const int fd = g_wake_fd.load();
  if (fd >= 0) {
    const char byte = 's';
    [[maybe_unused]] const ssize_t written = ::write(fd, &byte, 1);
  }
}

// Reads stdin on its own thread and hands out whole lines.
//
// On a terminal (a non-empty prompt) the line is edited with libedit: Left/Right, Home/End, history on
// Up/Down, Ctrl-R search, the user's ~/.editrc. libedit's readline interface has one global state and is
// not thread-safe, so only this thread touches it: while it edits, every output line of the process is
// handed to it (LinePrinter::set_output_handler; printing from the other threads under a lock would not
// do: a key sequence in progress blocks inside libedit, and the I/O thread must never wait for a key) and
// printed between keystrokes above the edited line, which is then drawn again, prompt and typed text
// included. From a pipe or a file: plain reads, split at newlines.
class LineReader {
 public:
  explicit LineReader(std::string prompt) : prompt_(std::move(prompt)) {
    if (::pipe(wake_) != 0) throw std::system_error(errno, std::generic_category(), "pipe");
    ::fcntl(wake_[1], F_SETFL, O_NONBLOCK);
    g_wake_fd = wake_[1];
    if (editing()) {
      out().set_output_handler([this](const std::string& text) { print_later(text); });
    }
    thread_ = std::thread([this] { run(); });
  }
  ~LineReader() {
    wake();
    thread_.join();
    g_wake_fd = -1;
    ::close(wake_[0]);
    ::close(wake_[1]);
  }
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// The next line (without its newline); nothing at end of input or after `wake()`.
  std::optional<std::string> next() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return !lines_.empty() || finished_; });
    if (lines_.empty()) return std::nullopt;
    std::string line = std::move(lines_.front());
    lines_.pop_front();
    return line;
  }

  /// Ends the input (the reader stops; `next()` returns nothing once the lines read are taken).
  void wake() {
    stop_ = true;
    poke();
  }

 private:
  bool editing() const { return !prompt_.empty(); }

  void poke() {
    const char byte = 'w';
    [[maybe_unused]] const ssize_t written = ::write(wake_[1], &byte, 1);
  }

  void print_later(const std::string& text) {
    {
      const std::lock_guard lock(mutex_);
      output_.push_back(text);
    }
    poke();
  }

  // Prints the lines handed over, above the edited line (reader thread only).
  void print_pending() {
    std::deque<std::string> output;
    {
      const std::lock_guard lock(mutex_);
      output.swap(output_);
    }
    if (output.empty()) return;
    std::fputs("\r\033[K", stdout);  // the prompt and the typed text go, the lines take their place...
    for (const std::string& text : output) {
      std::fputs(text.c_str(), stdout);
      std::fputc('\n', stdout);
    }
    cli::out().flush();
    rl_forced_update_display();  // ...and are drawn again below them
  }

  void add_line(std::string line) {
    const std::lock_guard lock(mutex_);
    lines_.push_back(std::move(line));
    changed_.notify_all();
  }

  // libedit's line handler: a whole line, or nullptr at end of input (Ctrl-D on an empty line).
  static void on_edited_line(char* line) {
    LineReader* reader = editing_reader_;
    if (line == nullptr) {
      reader->end_of_input_ = true;
      return;
    }
    if (*line != '\0') add_history(line);
    reader->add_line(line);
    reader->line_completed_ = true;
    std::free(line);
  }

  void run() {
    if (editing()) {
      editing_reader_ = this;
      rl_readline_name = const_cast<char*>("tether");
      rl_catch_signals = 0;  // SIGINT/SIGTERM are the shell's (they end it cleanly, terminal restored)
      rl_callback_handler_install(prompt_.c_str(), &LineReader::on_edited_line);
    }
    std::string pending;
    char buffer[4096];
    while (!stop_ && !end_of_input_) {
      pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {wake_[0], POLLIN, 0}};
      const int ready = ::poll(fds, 2, -1);
      if (ready < 0) {
        if (errno == EINTR) continue;
        break;
      }
      if (fds[1].revents != 0) {
        [[maybe_unused]] const ssize_t drained = ::read(wake_[0], buffer, sizeof buffer);
        if (g_stop_signalled) break;
        if (editing()) print_pending();
        continue;
      }
      if (fds[0].revents == 0) continue;
      if (editing()) {
        if ((fds[0].revents & POLLIN) == 0) break;  // the terminal went away
        rl_callback_read_char();                     // one key; a finished line arrives in on_edited_line
        if (line_completed_) {
          // Start the next line now: prompt drawn, buffer empty. (libedit 3.1-20221030 leaves its unbuffered
          // mode after a line, so the next key would start a blocking read of a whole line, and a redraw
          // meanwhile would show the old text.)
          line_completed_ = false;
          rl_callback_handler_install(prompt_.c_str(), &LineReader::on_edited_line);
        }
        continue;
      }
      const ssize_t size = ::read(STDIN_FILENO, buffer, sizeof buffer);
      if (size < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (size <= 0) break;  // end of input (or a vanished terminal)
      pending.append(buffer, static_cast<std::size_t>(size));
      for (std::size_t newline = pending.find('\n'); newline != std::string::npos; newline = pending.find('\n')) {
        std::string line = pending.substr(0, newline);
        pending.erase(0, newline + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        add_line(std::move(line));
      }
    }
    if (editing()) {
      out().set_output_handler({});  // lines print directly again (in order: the held ones first)
      print_pending();
      std::fputs("\r\033[K", stdout);  // no prompt left behind
      cli::out().flush();
      rl_callback_handler_remove();  // the terminal's own mode again
      editing_reader_ = nullptr;
    }
    const std::lock_guard lock(mutex_);
    if (!pending.empty()) lines_.push_back(std::move(pending));
    finished_ = true;
    changed_.notify_all();
  }

  static inline LineReader* editing_reader_ = nullptr;  // whose lines libedit's callback delivers
  std::string prompt_;
  int wake_[2] = {-1, -1};
  std::atomic<bool> stop_{false};
  bool end_of_input_ = false;   // reader thread only
  bool line_completed_ = false;  // reader thread only
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::string> lines_;
  std::deque<std::string> output_;
  bool finished_ = false;
  std::thread thread_;
};

std::string trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) text.remove_suffix(1);
  return std::string(text);
}

std::vector<std::string> split_words(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> words;
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

}  // namespace

int run_shell(int argc, char** argv) {
  ShellArguments arguments;
  if (const auto status = parse_shell_arguments(argc, argv, arguments)) return *status;
  std::string error;
  const auto target = resolve_device(arguments.device, default_codec(), error);
  if (!target) return shell_command().usage_error(error);
  const devices::Codec codec = target->config.codec;
  const CodecCommands& commands = *codec_commands(codec);
  if (!commands.open_shell) {
    return shell_command().usage_error(target->label + ": the shell does not speak " +
                                      std::string(devices::to_string(codec)));
  }

  const ShellPrinter printer{arguments.json};
  // Set when the link fails: the main thread stops reading input.
  auto link_failed = std::make_shared<std::atomic<bool>>(false);
  // The reader to wake when the link fails (the I/O thread calls on_failure; the main thread owns the reader).
  struct WakeTarget {
    std::mutex mutex;
    LineReader* reader = nullptr;
  };
  auto wake_target = std::make_shared<WakeTarget>();
  // The supervised serial port, once open: a link failure during its outage is the outage, not the end.
  struct PortHolder {
    std::mutex mutex;
    std::weak_ptr<transports::SerialPortStream> port;  // weak: the port's own handler reaches this holder
  };
  auto port_holder = std::make_shared<PortHolder>();
  ShellContext context;
  context.printer = printer;
  context.options = &arguments.device;
  context.link_failed = [link_failed, wake_target, port_holder] {
    {
      const std::lock_guard lock(port_holder->mutex);
      const auto port = port_holder->port.lock();
      if (port && port->options().reconnect.enabled && !port->link_counters().gave_up) return;
    }
    *link_failed = true;
    const std::lock_guard lock(wake_target->mutex);
    if (wake_target->reader != nullptr) wake_target->reader->wake();
  };

  // Before the session: a session that holds a client (one made by an opening that then failed) is
  // destroyed while the I/O context its timers belong to still exists.
  transports::IoThread io;
  // The codec's shell, created with the client: its event handlers see everything from the first byte on.
  std::unique_ptr<ShellSession> session;
  ClientHooks hooks;
  hooks.on_client = [&](const devices::DeviceClient& client) {
    session = commands.open_shell(client, target->config, context);
  };
  hooks.stopped = [] { return g_stop_signalled.load(); };

  // Caught from before the opening: a stop signal while the device opens ends the shell (exit 0) as later.
  g_stop_signalled = false;
  handle_stop_signals(on_stop_signal);
  Progress progress("shell");
  auto device = open_device(*target, io.executor(), hooks, progress, error);
  if (!device && g_stop_signalled) return 0;
  if (!device) return shell_command().fail(target->label + ": " + error);
  if (g_stop_signalled) {
    device->close();
    return 0;
  }

  const auto boot_line = [](const transports::BootReport& boot) {
    std::string text = "ready after " + std::to_string(boot.ready_after.count()) + " ms";
    if (boot.outcome == transports::BootOutcome::announced) text += " (the board announced its boot)";
    if (boot.outcome == transports::BootOutcome::probed) text += " (it answered probe " + std::to_string(boot.probes) + ")";
    if (boot.outcome == transports::BootOutcome::waited) text += " (fixed boot wait)";
    if (boot.outcome == transports::BootOutcome::upper_bound) text += " (no sign of a boot: the whole boot wait)";
    return text;
  };
  const auto boot_fields = [](const transports::BootReport& boot) {
    return nlohmann::ordered_json{{"ready_after_ms", boot.ready_after.count()},
                                  {"mode", transports::to_string(boot.mode)},
                                  {"outcome", transports::to_string(boot.outcome)}};
  };
  const auto& opened_port = device->port();
  const bool boot_waits = opened_port && opened_port->options().boot != transports::BootMode::none &&
                          opened_port->options().boot_wait.count() > 0;
  if (const auto& port = device->port(); port && port->options().reconnect.enabled) {
    // The outage as it happens; giving up ends the shell like a failed link.
    port->add_link_handler([printer, context_failed = context.link_failed, boot_waits, boot_line,
                            boot_fields](const transports::LinkEvent& event) {
      switch (event.kind) {
        case transports::LinkEvent::Kind::down:
          printer.info("link_down", "link down: " + event.reason, {{"reason", event.reason}});
          break;
        case transports::LinkEvent::Kind::up:
          printer.info("link_up", "link up after " + std::to_string(event.down_for.count()) + " ms (" + event.path + ")",
                       {{"down_ms", event.down_for.count()}, {"path", event.path}});
          if (boot_waits) printer.info("ready", boot_line(event.boot), boot_fields(event.boot));
          break;
        case transports::LinkEvent::Kind::gave_up:
          printer.info("link_lost",
                       "link lost: " + event.reason + " (gave up after " + std::to_string(event.attempts) + " attempts)",
                       {{"reason", event.reason}, {"attempts", event.attempts}});
          context_failed();
          break;
      }
    });
    const std::lock_guard lock(port_holder->mutex);
    port_holder->port = port;
  }

  const bool interactive = ::isatty(STDIN_FILENO) == 1 && ::isatty(STDOUT_FILENO) == 1;
  const std::string prompt = interactive ? std::string(devices::to_string(codec)) + "> " : std::string();
  printer.info("open", "connected to " + device->description() + "; :help for help, :quit to leave",
               {{"device", device->description()}, {"codec", std::string(devices::to_string(codec))}});
  if (boot_waits) printer.info("ready", boot_line(opened_port->boot_report()), boot_fields(opened_port->boot_report()));
  session->greet();

  auto reader = std::make_unique<LineReader>(prompt);
  {
    const std::lock_guard lock(wake_target->mutex);
    wake_target->reader = reader.get();
  }

  const auto started = std::chrono::steady_clock::now();
  int status = 0;
  for (;;) {
    if (*link_failed) {
      status = 2;
      break;
    }
    const std::optional<std::string> read = reader->next();
    if (*link_failed) {
      status = 2;
      break;
    }
    if (!read) {
      session->finish(g_stop_signalled);  // waits for the answers to what was sent: the link may fail meanwhile
      if (*link_failed) status = 2;
      break;
    }
    if (g_stop_signalled) {  // lines read before the signal are not sent: it ends the shell now
      session->finish(g_stop_signalled);
      if (*link_failed) status = 2;
      break;
    }
    const std::string line = trim(*read);
    if (line.empty()) continue;

    if (line.starts_with(':')) {
      const std::vector<std::string> words = split_words(line);
      const std::string& command = words[0];
      if (command == ":quit" || command == ":q" || command == ":exit") break;
      if (command == ":help") {
        const std::string help = commands.shell_help(target->config);
        printer.info("help", help, {{"text", help}});
      } else if (command == ":stats") {
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        const nlohmann::ordered_json report = stats_report(*device, seconds);
        if (arguments.json) {
          printer.info("stats", "", {{"stats", report}});
        } else {
          std::string table = counters_table(report);
          if (!table.empty() && table.back() == '\n') table.pop_back();
          out().line(table);
        }
      } else if (!session->command(words)) {
        printer.error("unknown shell command " + command + " (:help, :stats, :quit)");
      }
      continue;
    }
    session->send(line);
  }
  {
    const std::lock_guard lock(wake_target->mutex);
    wake_target->reader = nullptr;
  }
  reader.reset();
  device->close();
  session.reset();
  if (status != 0) std::fprintf(stderr, "tether shell: the link to %s failed\n", device->description().c_str());
  return status;
}

}  // namespace tether::cli
