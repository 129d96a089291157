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
#include "commands.hpp"
#include "device_options.hpp"
#include "message_text.hpp"
#include "shell_text.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::cli {

namespace {

const CommandText& command_text() {
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
      kDeviceUsage +
      "\n"
      "  --json         every output line is a JSON object with a \"type\": answer, log, sent, event, stats,\n"
      "                 error, open\n"
      "\n"
      "Exit status: 0 :quit, end of input, SIGINT/SIGTERM; 2 usage errors, a device that cannot be opened,\n"
      "a link that failed.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct Arguments {
  DeviceOptions device;
  bool json = false;
};

std::optional<int> parse(int argc, char** argv, Arguments& arguments) {
  const CommandText& text = command_text();
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
    std::fflush(stdout);
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
      std::fflush(stdout);
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

// How the shell prints: text or JSON lines, from any thread.
struct Printer {
  bool json = false;

  void print(std::string_view type, const ShellLine& line) const { out().line(shell_output(type, line, json)); }
  void answer(const ShellLine& line) const { print("answer", line); }
  void event(const ShellLine& line) const { print("event", line); }
  void error(const std::string& text) const { print("error", {"error: " + text, {{"message", text}}}); }
  void info(const std::string& type, const std::string& text, const nlohmann::ordered_json& object) const {
    print(type, {text, object});
  }
};

std::string help_text(devices::Codec codec) {
  std::string text;
  switch (codec) {
    case devices::Codec::romi:
      text =
          "Type a Romi command: an opcode and its arguments, the device's own (romi-test: e, s[2,3], t[\"hello\"],\n"
          "g[2]; romi-blink: L[1]; romi-rover: S[1500,1500], A[0]). The id, CRC and framing are added; the\n"
          "answer array is printed. Log lines from the device appear as `log: text`.\n";
      break;
    case devices::Codec::proxy:
    case devices::Codec::proxy_compat: {
      const proxy::Mode mode = codec == devices::Codec::proxy ? proxy::Mode::primary : proxy::Mode::compat;
      text = "Type a message and its fields (FIELD=VALUE, every field):\n" + proxy_message_list(mode, "  ") +
             "Device errors, pin states, info and session changes appear as they arrive.\n";
      break;
    }
    case devices::Codec::elcano:
      text =
          "Type a message: D{s 50}{a 25} (drive), S{s 1}{a 2}{b 3}{p 4,5} (sensor), G{n 1}{p 0,0}{b 90} (goal),\n"
          "X{n 1}{p 0,0}{b 90}{s 50} (segment); it is sent into the ring. Captured messages and messages that\n"
          "came back undelivered appear as they arrive. :capture TYPES sets the types the host consumes\n"
          "(drive,sensor,goal,segment or none).\n";
      break;
  }
  return text + "Shell commands: :help, :stats (the session's counters), :quit (or Ctrl-D).";
}

// What became of the messages sent into an Elcano ring: each one ends captured somewhere (what the host
// sees is the answer it captures) or back at the host undelivered. End of input waits for these (bounded),
// so `echo 'D{s 50}{a 25}' | tether shell ...` prints the answer before it exits.
class RingReplies {
 public:
  /// How long end of input waits, at most, for the replies still outstanding.
  static constexpr std::chrono::seconds kWait{3};

  void sent() {
    const std::lock_guard lock(mutex_);
    ++sent_;
  }
  /// A captured message or an undelivered one came back.
  void settled() {
    const std::lock_guard lock(mutex_);
    ++settled_;
    changed_.notify_all();
  }
  /// Waits until every message sent has settled or `kWait` passed (or `stop` is set).
  void wait(const std::atomic<bool>& stop) {
    std::unique_lock lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (settled_ < sent_ && !stop && std::chrono::steady_clock::now() < deadline) {
      changed_.wait_for(lock, std::chrono::milliseconds(50));  // 50 ms steps: notices a stop signal
    }
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::uint64_t sent_ = 0;
  std::uint64_t settled_ = 0;
};

// Prints every captured message: one receive at a time, re-armed from its completion.
void receive_captured(std::weak_ptr<elcano::RingClient> weak, Printer printer, elcano::Generation generation,
                      std::shared_ptr<RingReplies> replies) {
  const auto ring = weak.lock();
  if (!ring || !ring->is_open()) return;
  ring->async_receive([weak, printer, generation, replies](elcano::error_code error, elcano::Message message) {
    if (error) return;  // closed, or the link failed (reported as an event)
    printer.event(captured_line(message, generation));
    replies->settled();
    receive_captured(weak, printer, generation, replies);
  });
}

}  // namespace

int run_shell(int argc, char** argv) {
  Arguments arguments;
  if (const auto status = parse(argc, argv, arguments)) return *status;
  std::string error;
  const auto target = resolve_device(arguments.device, devices::Codec::romi, error);
  if (!target) return command_text().usage_error(error);
  const devices::Codec codec = target->config.codec;
  const elcano::Generation generation = codec == devices::Codec::elcano
                                            ? std::get<devices::ElcanoOptions>(target->config.options).generation
                                            : elcano::Generation::b;

  Printer printer{arguments.json};
  // Set when the link fails: the main thread stops reading input.
  auto link_failed = std::make_shared<std::atomic<bool>>(false);
  // The reader to wake when the link fails (the I/O thread calls on_failure; the main thread owns the reader).
  struct WakeTarget {
    std::mutex mutex;
    LineReader* reader = nullptr;
  };
  auto wake_target = std::make_shared<WakeTarget>();
  auto on_failure = [link_failed, wake_target] {
    *link_failed = true;
    const std::lock_guard lock(wake_target->mutex);
    if (wake_target->reader != nullptr) wake_target->reader->wake();
  };

  auto ring_replies = std::make_shared<RingReplies>();
  ClientHooks hooks;
  hooks.romi_events = [printer, on_failure](const romi::Event& event) {
    if (const auto* log = std::get_if<romi::events::Log>(&event)) {
      printer.event(romi_log_line(log->text));
      return;
    }
    const romi::error_code failure = std::get<romi::events::LinkFailed>(event).error;
    printer.event({"link failed: " + failure.message(), {{"event", "link_failed"}, {"message", failure.message()}}});
    on_failure();
  };
  hooks.proxy_events = [printer, on_failure](const proxy::Event& event) {
    printer.event(proxy_event_line(event));
    if (std::holds_alternative<proxy::events::LinkFailed>(event)) on_failure();
  };
  hooks.ring_events = [printer, generation, on_failure, ring_replies](const elcano::Event& event) {
    printer.event(ring_event_line(event, generation));
    if (std::holds_alternative<elcano::events::Undeliverable>(event)) ring_replies->settled();
    if (std::holds_alternative<elcano::events::LinkFailed>(event)) on_failure();
  };

  transports::IoThread io;
  Progress progress("shell");
  auto device = open_device(*target, io.executor(), hooks, progress, error);
  if (!device) return command_text().fail(target->label + ": " + error);
  if (device->ring()) receive_captured(device->ring(), printer, generation, ring_replies);

  const bool interactive = ::isatty(STDIN_FILENO) == 1 && ::isatty(STDOUT_FILENO) == 1;
  const std::string prompt = interactive ? std::string(devices::to_string(codec)) + "> " : std::string();
  printer.info("open", "connected to " + device->description() + "; :help for help, :quit to leave",
               {{"device", device->description()}, {"codec", std::string(devices::to_string(codec))}});
  if (codec == devices::Codec::elcano && !arguments.device.firmware.empty()) {  // --virtual: a ring of one
    const std::string capture = arguments.device.capture ? "as --capture says" : "sensor messages";
    printer.info("note",
                 "the virtual board captures drive messages and answers each with a sensor report; the host "
                 "captures " + capture + "; other messages come back undelivered",
                 {{"board_captures", "drive"}});
  }

  g_stop_signalled = false;
  auto reader = std::make_unique<LineReader>(prompt);
  {
    const std::lock_guard lock(wake_target->mutex);
    wake_target->reader = reader.get();
  }
  handle_stop_signals(on_stop_signal);

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
      if (device->ring()) ring_replies->wait(g_stop_signalled);
      break;
    }
    const std::string line = trim(*read);
    if (line.empty()) continue;

    if (line.starts_with(':')) {
      const std::vector<std::string> words = split_words(line);
      const std::string& command = words[0];
      if (command == ":quit" || command == ":q" || command == ":exit") break;
      if (command == ":help") {
        printer.info("help", help_text(codec), {{"text", help_text(codec)}});
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
      } else if (command == ":capture" && device->ring()) {
        const std::optional<elcano::TypeSet> set =
            words.size() == 2 ? parse_elcano_types(words[1]) : std::optional<elcano::TypeSet>();
        const bool valid = set.has_value();
        if (!valid) {
          printer.error(":capture needs TYPES: drive,sensor,goal,segment or none");
        } else {
          device->ring()->set_capture(*set);
          printer.info("capture", "capturing " + words[1], {{"capture", words[1]}});
        }
      } else {
        printer.error("unknown shell command " + command + " (:help, :stats, :quit)");
      }
      continue;
    }

    if (const auto& romi = device->romi()) {
      const romi::Command command(line);
      romi::error_code call_error;
      const romi::RomiResponse response = romi->call(command, call_error);
      printer.answer(romi_answer_line(line, response));
    } else if (const auto& client = device->proxy()) {
      const std::vector<std::string> words = split_words(line);
      auto command = parse_proxy_command(client->mode(), words, error);
      if (!command) {
        printer.error(error);
        continue;
      }
      if (command->reset && client->mode() == proxy::Mode::primary) {
        client->restart_session();
        printer.answer(
            {"restarting the session (Reset, ResetEvent, inits)", {{"message", "reset"}, {"restarting", true}}});
        continue;
      }
      proxy::error_code send_error;
      proxy::SendResult sent;
      if (const auto* primary = std::get_if<proxy::ArduinoIn>(&command->message)) {
        sent = client->send(*primary, send_error);
      } else {
        sent = client->send(std::get<RocketryProto::ArduinoIn>(command->message), send_error);
      }
      nlohmann::ordered_json object = {
          {"message", command->name},
          {"acked", sent.acked},
          {"written", !send_error},
          {"message_id", sent.message_id},
          {"attempts", sent.attempts},
          {"error", send_error ? nlohmann::ordered_json(send_error.message()) : nlohmann::ordered_json()}};
      std::string text;
      if (send_error) {
        text = command->name + " failed: " + send_error.message();
      } else if (sent.acked) {
        text = command->name + " acked (message id " + std::to_string(sent.message_id) + ", " +
               std::to_string(sent.attempts) + (sent.attempts == 1 ? " attempt)" : " attempts)");
      } else {
        text = command->name + " written";
      }
      printer.answer({text, object});
    } else if (const auto& ring = device->ring()) {
      const auto message = parse_elcano(line, error);
      if (!message) {
        printer.error(error);
        continue;
      }
      elcano::error_code send_error;
      ring_replies->sent();  // before sending: the reply can come back before `send` returns
      ring->send(*message, send_error);
      const std::string text = format_elcano(*message, generation);
      if (send_error) {
        ring_replies->settled();  // nothing will come of it
        printer.answer({"send failed: " + send_error.message(),
                        {{"text", text}, {"sent", false}, {"error", send_error.message()}}});
      } else {
        printer.answer({"sent " + text, {{"text", text}, {"sent", true}, {"message", elcano_json(*message)}}});
      }
    }
  }
  {
    const std::lock_guard lock(wake_target->mutex);
    wake_target->reader = nullptr;
  }
  reader.reset();
  device->close();
  if (status != 0) std::fprintf(stderr, "tether shell: the link to %s failed\n", device->description().c_str());
  return status;
}

}  // namespace tether::cli
