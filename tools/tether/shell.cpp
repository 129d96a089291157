// `tether shell DEVICE [--json]`: an interactive terminal for a device. Lines typed are sent in the
// device's protocol (romi `s[2,3]`, proxy `servo-control pin=9 position=90`, elcano `D{s 50}{a 25}`), and
// what the device says on its own (romi log lines, proxy events, captured or undeliverable ring messages)
// is printed as it arrives, also while nobody types.
//
// Threads: a reader thread reads stdin (poll + read, line by line, so a terminal in canonical mode, a pipe
// and a file all work) and hands lines to the main thread, which runs each line with the client's
// blocking API; the I/O thread runs the client and prints its events. So stdin never blocks the asio loop
// and device events appear while the user is idle. Lines are printed whole (cli_support's LinePrinter);
// on a terminal an asynchronous line erases the prompt and draws it again.
//
// Exit status: 0 on `:quit` or end of input (Ctrl-D) or SIGINT/SIGTERM; 2 usage errors, a device that
// cannot be opened, a link that failed (the device went away).
#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
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
          "input (Ctrl-D) quits too. Works on a terminal (the line is edited by the terminal) and with stdin\n"
          "from a pipe or a file (one message per line).\n"
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

// The write end of the pipe that wakes the reader (signals, link failure).
std::atomic<int> g_wake_fd{-1};

void on_stop_signal(int) {
  const int fd = g_wake_fd.load();
  if (fd >= 0) {
    const char byte = 's';
    [[maybe_unused]] const ssize_t written = ::write(fd, &byte, 1);
  }
}

// Reads stdin on its own thread and hands out whole lines.
class LineReader {
 public:
  LineReader() {
    if (::pipe(wake_) != 0) throw std::system_error(errno, std::generic_category(), "pipe");
    ::fcntl(wake_[1], F_SETFL, O_NONBLOCK);
    g_wake_fd = wake_[1];
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
    const char byte = 'w';
    [[maybe_unused]] const ssize_t written = ::write(wake_[1], &byte, 1);
  }

 private:
  void run() {
    std::string pending;
    char buffer[4096];
    for (;;) {
      pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {wake_[0], POLLIN, 0}};
      const int ready = ::poll(fds, 2, -1);
      if (ready < 0) {
        if (errno == EINTR) continue;
        break;
      }
      if (fds[1].revents != 0) break;
      if (fds[0].revents == 0) continue;
      const ssize_t size = ::read(STDIN_FILENO, buffer, sizeof buffer);
      if (size < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (size <= 0) break;  // end of input (or a vanished terminal)
      pending.append(buffer, static_cast<std::size_t>(size));
      for (std::size_t newline = pending.find('\n'); newline != std::string::npos; newline = pending.find('\n')) {
        std::string line = pending.substr(0, newline);
        pending.erase(0, newline + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::lock_guard lock(mutex_);
        lines_.push_back(std::move(line));
        changed_.notify_all();
      }
    }
    const std::lock_guard lock(mutex_);
    if (!pending.empty()) lines_.push_back(std::move(pending));
    finished_ = true;
    changed_.notify_all();
  }

  int wake_[2] = {-1, -1};
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::string> lines_;
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

  void answer(const std::string& text, const nlohmann::ordered_json& object) const {
    emit("answer", text, object, false);
  }
  void event(const std::string& text, const nlohmann::ordered_json& object) const { emit("event", text, object, true); }
  void error(const std::string& text) const { emit("error", "error: " + text, {{"message", text}}, false); }
  void info(const std::string& type, const std::string& text, const nlohmann::ordered_json& object) const {
    emit(type, text, object, false);
  }

  void emit(const std::string& type, const std::string& text, const nlohmann::ordered_json& object,
            bool asynchronous) const {
    std::string line = text;
    if (json) {
      nlohmann::ordered_json full = {{"type", type}};
      for (const auto& [key, value] : object.items()) full[key] = value;
      line = dump(full);
    }
    if (asynchronous) {
      out().async_line(line);
    } else {
      out().line(line);
    }
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

// --- event formatting ----------------------------------------------------------------------------------

void print_proxy_event(const Printer& printer, const proxy::ProxyEvent& event) {
  namespace ev = proxy::events;
  if (const auto* error = std::get_if<ev::DeviceError>(&event)) {
    printer.event(
        std::string("device ") + (error->level == proxy::ErrorLevel::fatal ? "FATAL" : "error") + ": " + error->text,
        {{"event", "device_error"},
         {"text", error->text},
         {"level", error->level == proxy::ErrorLevel::fatal ? "fatal" : "warning"}});
  } else if (const auto* info = std::get_if<ev::DeviceInfo>(&event)) {
    printer.event("info: session " + std::to_string(info->session_id) +
                      (info->ping_failsafe_triggered ? ", failsafe triggered" : ""),
                  {{"event", "info"},
                   {"session_id", info->session_id},
                   {"ping_failsafe_triggered", info->ping_failsafe_triggered}});
  } else if (const auto* failsafe = std::get_if<ev::FailsafeTriggered>(&event)) {
    printer.event("FAILSAFE triggered (no ping for 10 s)",
                  {{"event", "failsafe"}, {"session_id", failsafe->session_id}});
  } else if (const auto* report = std::get_if<ev::PinReport>(&event)) {
    const char* kind = report->kind == proxy::PinKind::servo     ? "servo"
                       : report->kind == proxy::PinKind::digital ? "digital"
                                                                 : "pin";
    printer.event(std::string(kind) + " " + std::to_string(report->pin) + " = " + std::to_string(report->value) +
                      (report->failsafe ? " (failsafe)" : ""),
                  {{"event", "pin"},
                   {"kind", kind},
                   {"pin", report->pin},
                   {"value", report->value},
                   {"failsafe", report->failsafe}});
  } else if (const auto* lost = std::get_if<ev::PinLost>(&event)) {
    printer.event("pin " + std::to_string(lost->pin) + " lost (silent " + std::to_string(lost->silent_ms) + " ms)",
                  {{"event", "pin_lost"}, {"pin", lost->pin}, {"silent_ms", lost->silent_ms}});
  } else if (const auto* established = std::get_if<ev::SessionEstablished>(&event)) {
    printer.event("session " + std::to_string(established->session_id) + " established" +
                      (established->inits > 0 ? " (" + std::to_string(established->inits) + " inits replayed)" : ""),
                  {{"event", "session"},
                   {"session_id", established->session_id},
                   {"inits", established->inits},
                   {"first", established->first}});
  } else if (const auto* reset = std::get_if<ev::ResetDetected>(&event)) {
    printer.event("device reset detected (session " + std::to_string(reset->previous_session_id) + " -> " +
                      std::to_string(reset->reported_session_id) + "); recovering",
                  {{"event", "reset_detected"},
                   {"previous_session_id", reset->previous_session_id},
                   {"reported_session_id", reset->reported_session_id}});
  } else if (const auto* compat = std::get_if<ev::CompatEvent>(&event)) {
    const std::string name = RocketryProto::EventTypes_Name(compat->type);
    printer.event("device event " + name + " " + std::to_string(compat->data),
                  {{"event", "compat_event"}, {"name", name}, {"data", compat->data}});
  } else if (const auto* compat_error = std::get_if<ev::CompatError>(&event)) {
    const std::string name = RocketryProto::ErrorTypes_Name(compat_error->type);
    printer.event("device error " + name + " " + std::to_string(compat_error->data),
                  {{"event", "compat_error"}, {"name", name}, {"data", compat_error->data}});
  } else if (const auto* state = std::get_if<ev::CompatState>(&event)) {
    printer.event("device state " + describe_proxy_message(state->message),
                  {{"event", "compat_state"}, {"message", proxy_message_json(state->message)}});
  } else if (const auto* undecodable = std::get_if<ev::UndecodableMessage>(&event)) {
    printer.event(std::string(undecodable->malformed ? "undecodable" : "unknown") + " message (" +
                      std::to_string(undecodable->payload.size()) + " bytes)",
                  {{"event", "undecodable"}, {"malformed", undecodable->malformed}});
  } else if (const auto* failed = std::get_if<ev::LinkFailed>(&event)) {
    printer.event("link failed: " + failed->error.message(),
                  {{"event", "link_failed"}, {"message", failed->error.message()}});
  }
}

void print_ring_event(const Printer& printer, elcano::Generation generation, const elcano::ClientEvent& event) {
  using Kind = elcano::ClientEvent::Kind;
  switch (event.kind) {
    case Kind::undeliverable: {
      const std::string text = format_elcano(event.message, generation);
      printer.event("undeliverable " + text + " (came back round the ring: nobody captured it)",
                    {{"event", "undeliverable"}, {"text", text}, {"message", elcano_json(event.message)}});
      break;
    }
    case Kind::read_error:
      printer.event(std::string("read error: ") + elcano::to_string(event.error),
                    {{"event", "read_error"}, {"reason", elcano::to_string(event.error)}});
      break;
    case Kind::forward_dropped: {
      const std::string text = format_elcano(event.message, generation);
      printer.event("forward dropped " + text + " (output queue full)", {{"event", "forward_dropped"}, {"text", text}});
      break;
    }
    case Kind::receive_overflow: {
      const std::string text = format_elcano(event.message, generation);
      printer.event("receive overflow, dropped " + text, {{"event", "receive_overflow"}, {"text", text}});
      break;
    }
    case Kind::link_failed:
      printer.event("link failed: " + event.link_error.message(),
                    {{"event", "link_failed"}, {"message", event.link_error.message()}});
      break;
  }
}

// Prints every captured message: one receive at a time, re-armed from its completion.
void receive_captured(std::weak_ptr<elcano::RingClient> weak, Printer printer, elcano::Generation generation) {
  const auto ring = weak.lock();
  if (!ring || !ring->is_open()) return;
  ring->async_receive([weak, printer, generation](elcano::error_code error, elcano::Message message) {
    if (error) return;  // closed, or the link failed (reported as an event)
    const std::string text = format_elcano(message, generation);
    printer.event("captured " + text, {{"event", "captured"}, {"text", text}, {"message", elcano_json(message)}});
    receive_captured(weak, printer, generation);
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

  ClientHooks hooks;
  hooks.romi_log = [printer](std::string_view text) {
    printer.event("log: " + std::string(text), {{"event", "log"}, {"text", std::string(text)}});
  };
  hooks.romi_link_failed = [printer, on_failure](romi::error_code failure) {
    printer.event("link failed: " + failure.message(), {{"event", "link_failed"}, {"message", failure.message()}});
    on_failure();
  };
  hooks.proxy_events = [printer, on_failure](const proxy::ProxyEvent& event) {
    print_proxy_event(printer, event);
    if (std::holds_alternative<proxy::events::LinkFailed>(event)) on_failure();
  };
  hooks.ring_events = [printer, generation, on_failure](const elcano::ClientEvent& event) {
    print_ring_event(printer, generation, event);
    if (event.kind == elcano::ClientEvent::Kind::link_failed) on_failure();
  };

  transports::IoThread io;
  Progress progress("shell");
  auto device = open_device(*target, io.executor(), hooks, progress, error);
  if (!device) return command_text().fail(target->label + ": " + error);
  if (device->ring()) receive_captured(device->ring(), printer, generation);

  const bool interactive = ::isatty(STDIN_FILENO) == 1 && ::isatty(STDOUT_FILENO) == 1;
  const std::string prompt = interactive ? std::string(devices::to_string(codec)) + "> " : std::string();
  printer.info("open", "connected to " + device->description() + "; :help for help, :quit to leave",
               {{"device", device->description()}, {"codec", std::string(devices::to_string(codec))}});

  auto reader = std::make_unique<LineReader>();
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
    if (!prompt.empty()) {
      out().set_prompt(prompt, true);
      out().raw(prompt);
    }
    const std::optional<std::string> read = reader->next();
    out().set_prompt(prompt, false);
    if (*link_failed) {
      status = 2;
      break;
    }
    if (!read) break;
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
      nlohmann::ordered_json object = {{"command", line},
                                       {"code", response.code},
                                       {"values", response.values},
                                       {"answered", response.answered},
                                       {"message", response.message},
                                       {"id", response.id},
                                       {"attempts", response.attempts}};
      std::string text = response.answered ? dump(response.values) : std::string();
      if (response.code != 0) {
        text +=
            std::string(text.empty() ? "" : "  ") + "error " + std::to_string(response.code) + ": " + response.message;
      }
      printer.answer(text, object);
    } else if (const auto& client = device->proxy()) {
      const std::vector<std::string> words = split_words(line);
      auto command = parse_proxy_command(client->mode(), words, error);
      if (!command) {
        printer.error(error);
        continue;
      }
      if (command->reset && client->mode() == proxy::Mode::primary) {
        client->restart_session();
        printer.answer("restarting the session (Reset, ResetEvent, inits)",
                       {{"message", "reset"}, {"restarting", true}});
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
      printer.answer(text, object);
    } else if (const auto& ring = device->ring()) {
      const auto message = parse_elcano(line, error);
      if (!message) {
        printer.error(error);
        continue;
      }
      elcano::error_code send_error;
      ring->send(*message, send_error);
      const std::string text = format_elcano(*message, generation);
      if (send_error) {
        printer.answer("send failed: " + send_error.message(),
                       {{"text", text}, {"sent", false}, {"error", send_error.message()}});
      } else {
        printer.answer("sent " + text, {{"text", text}, {"sent", true}, {"message", elcano_json(*message)}});
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
