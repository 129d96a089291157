// The `tether` command's rows of the codec table (see codec_commands.hpp): romi, proxy, proxy-compat, elcano.
#include "codec_commands.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <variant>

#include "cli_support.hpp"
#include "device_options.hpp"
#include "message_text.hpp"
#include "tether/elcano/plugin.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/romi/plugin.hpp"

namespace tether::cli {

void ShellPrinter::print(std::string_view type, const ShellLine& line) const {
  out().line(shell_output(type, line, json));
}

nlohmann::ordered_json link_counters_json(const LinkCounters& counters) {
  return {{"frames_ok", counters.frames_ok},
          {"crc_errors", counters.crc_errors},
          {"framing_errors", counters.framing_errors},
          {"oversize_frames", counters.oversize_frames},
          {"resyncs", counters.resyncs},
          {"partial_timeouts", counters.partial_timeouts},
          {"stale", counters.stale},
          {"duplicates", counters.duplicates},
          {"retries", counters.retries},
          {"timeouts", counters.timeouts},
          {"resets", counters.resets},
          {"failsafes", counters.failsafes}};
}

namespace {

const char* const kShellCommands = "Shell commands: :help, :stats (the session's counters), :quit (or Ctrl-D).";

// --- romi -------------------------------------------------------------------------------------------------------

std::shared_ptr<romi::Client> romi_client(const devices::DeviceClient& client) {
  return client.get<romi::Client>();
}

class RomiShell final : public ShellSession {
 public:
  RomiShell(std::shared_ptr<romi::Client> client, const ShellContext& context)
      : client_(std::move(client)), printer_(context.printer) {
    const ShellPrinter printer = context.printer;
    const std::function<void()> link_failed = context.link_failed;
    client_->on_event([printer, link_failed](const romi::Event& event) {
      if (const auto* log = std::get_if<romi::events::Log>(&event)) {
        printer.event(romi_log_line(log->text));
        return;
      }
      const romi::error_code failure = std::get<romi::events::LinkFailed>(event).error;
      printer.event({"link failed: " + failure.message(), {{"event", "link_failed"}, {"message", failure.message()}}});
      link_failed();
    });
  }
  void send(const std::string& line) override {
    romi::error_code call_error;
    const romi::RomiResponse response = client_->call(romi::Command(line), call_error);
    printer_.answer(romi_answer_line(line, response));
  }

 private:
  std::shared_ptr<romi::Client> client_;
  ShellPrinter printer_;
};

CodecCommands romi_commands() {
  CodecCommands row;
  row.name = "romi";
  row.image_prefixes = {"romi"};
  row.default_options = [](std::uint32_t, const DeviceOptions&) -> devices::CodecOptions {
    return romi::DeviceOptions();
  };
  row.counters = [](const devices::DeviceClient& client) {
    return nlohmann::ordered_json{{"link", link_counters_json(romi_client(client)->counters().link)}};
  };
  row.shell_help = [](const devices::DeviceConfig&) {
    return std::string(
               "Type a Romi command: an opcode and its arguments, the device's own (romi-test: e, s[2,3], t[\"hello\"],\n"
               "g[2]; romi-blink: L[1]; romi-rover: S[1500,1500], A[0], L[1500,1500,\"label\"], R). The id, CRC and\n"
               "framing are added; the answer array is printed. Log lines from the device appear as `log: text`.\n") +
           kShellCommands;
  };
  row.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig&, const ShellContext& context) {
    return std::unique_ptr<ShellSession>(std::make_unique<RomiShell>(romi_client(client), context));
  };
  row.monitor_decoder = make_romi_monitor_decoder;
  row.default_probe = "?";
  row.check_probe = [](const std::string& probe) -> std::optional<std::string> {
    const romi::Command command(probe);
    if (command.valid()) return std::nullopt;
    return command.error_text();
  };
  row.send_probe = [](const devices::DeviceClient& client, const std::string& probe) {
    romi::error_code call_error;
    romi_client(client)->call(romi::Command(probe), call_error);
    return !call_error;
  };
  return row;
}

// --- proxy and proxy-compat -------------------------------------------------------------------------------------

std::shared_ptr<proxy::Client> proxy_client(const devices::DeviceClient& client) {
  return client.get<proxy::Client>();
}

class ProxyShell final : public ShellSession {
 public:
  ProxyShell(std::shared_ptr<proxy::Client> client, const ShellContext& context)
      : client_(std::move(client)), printer_(context.printer) {
    const ShellPrinter printer = context.printer;
    const std::function<void()> link_failed = context.link_failed;
    client_->on_event([printer, link_failed](const proxy::Event& event) {
      printer.event(proxy_event_line(event));
      if (std::holds_alternative<proxy::events::LinkFailed>(event)) link_failed();
    });
  }
  void send(const std::string& line) override {
    std::istringstream stream(line);
    std::vector<std::string> words;
    for (std::string word; stream >> word;) words.push_back(word);
    std::string error;
    auto command = parse_proxy_command(client_->mode(), words, error);
    if (!command) {
      printer_.error(error);
      return;
    }
    if (command->reset && client_->mode() == proxy::Mode::primary) {
      client_->restart_session();
      printer_.answer(
          {"restarting the session (Reset, ResetEvent, inits)", {{"message", "reset"}, {"restarting", true}}});
      return;
    }
    proxy::error_code send_error;
    proxy::SendResult sent;
    if (const auto* primary = std::get_if<proxy::ArduinoIn>(&command->message)) {
      sent = client_->send(*primary, send_error);
    } else {
      sent = client_->send(std::get<RocketryProto::ArduinoIn>(command->message), send_error);
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
    printer_.answer({text, object});
  }

 private:
  std::shared_ptr<proxy::Client> client_;
  ShellPrinter printer_;
};

CodecCommands proxy_commands(std::string_view name, proxy::Mode mode) {
  CodecCommands row;
  row.name = name;
  row.image_prefixes = {name};
  row.default_options = [mode](std::uint32_t baud, const DeviceOptions&) -> devices::CodecOptions {
    proxy::DeviceOptions options;
    options.client = mode == proxy::Mode::primary ? proxy::Options::primary() : proxy::Options::compat();
    options.client.timing.baud = baud;
    return options;
  };
  row.readying = "waiting for the proxy session and inits...";
  row.counters = [](const devices::DeviceClient& device_client) {
    const auto client = proxy_client(device_client);
    const proxy::Counters counters = client->counters();
    nlohmann::ordered_json report;
    report["link"] = link_counters_json(counters.link);
    report["proxy"] = {{"messages_sent", counters.messages_sent}, {"acks", counters.acks},
                       {"pings_sent", counters.pings_sent},       {"ping_acks", counters.ping_acks},
                       {"resets_sent", counters.resets_sent},     {"inits_replayed", counters.inits_replayed},
                       {"undecodable", counters.undecodable},     {"unknown_messages", counters.unknown_messages},
                       {"pins_lost", counters.pins_lost}};
    const proxy::SessionStatus session = client->session();
    report["session"] = {{"established", session.established}, {"session_id", nullptr}};
    if (session.session_id) report["session"]["session_id"] = *session.session_id;
    return report;
  };
  row.shell_help = [mode](const devices::DeviceConfig&) {
    return "Type a message and its fields (FIELD=VALUE, every field):\n" + proxy_message_list(mode, "  ") +
           "Device errors, pin states, info and session changes appear as they arrive.\n" + kShellCommands;
  };
  row.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig&, const ShellContext& context) {
    return std::unique_ptr<ShellSession>(std::make_unique<ProxyShell>(proxy_client(client), context));
  };
  row.monitor_decoder = make_proxy_monitor_decoder;
  row.monitor_keepalive = mode == proxy::Mode::primary;
  return row;
}

// --- elcano -----------------------------------------------------------------------------------------------------

std::shared_ptr<elcano::RingClient> ring_client(const devices::DeviceClient& client) {
  return client.get<elcano::RingClient>();
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
  /// The link failed: nothing more will come back.
  void link_failed() {
    const std::lock_guard lock(mutex_);
    link_failed_ = true;
    changed_.notify_all();
  }
  /// Waits until every message sent has settled, the link failed or `kWait` passed (or `stop` is set).
  void wait(const std::atomic<bool>& stop) {
    std::unique_lock lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (settled_ < sent_ && !link_failed_ && !stop && std::chrono::steady_clock::now() < deadline) {
      changed_.wait_for(lock, std::chrono::milliseconds(50));  // 50 ms steps: notices a stop signal
    }
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::uint64_t sent_ = 0;
  std::uint64_t settled_ = 0;
  bool link_failed_ = false;
};

// Prints every captured message: one receive at a time, re-armed from its completion.
void receive_captured(std::weak_ptr<elcano::RingClient> weak, ShellPrinter printer, elcano::Generation generation,
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

class ElcanoShell final : public ShellSession {
 public:
  ElcanoShell(std::shared_ptr<elcano::RingClient> client, const devices::DeviceConfig& config,
              const ShellContext& context)
      : client_(std::move(client)),
        printer_(context.printer),
        generation_(config.options.get<elcano::DeviceOptions>().generation),
        lone_board_(context.options != nullptr && !context.options->firmware.empty()),
        capture_given_(context.options != nullptr && context.options->capture.has_value()) {
    const ShellPrinter printer = context.printer;
    const std::function<void()> link_failed = context.link_failed;
    const elcano::Generation generation = generation_;
    const auto replies = replies_;
    client_->on_event([printer, generation, link_failed, replies](const elcano::Event& event) {
      printer.event(ring_event_line(event, generation));
      if (std::holds_alternative<elcano::events::Undeliverable>(event)) replies->settled();
      if (std::holds_alternative<elcano::events::LinkFailed>(event)) {
        link_failed();            // first: the shell's exit status reads it as soon as the wait below ends
        replies->link_failed();
      }
    });
    receive_captured(client_, printer_, generation_, replies_);
  }
  void greet() override {
    if (!lone_board_) return;  // --virtual: a ring of one
    const std::string capture = capture_given_ ? "as --capture says" : "sensor messages";
    printer_.info("note",
                  "the virtual board captures drive messages and answers each with a sensor report; the host "
                  "captures " + capture + "; other messages come back undelivered",
                  {{"board_captures", "drive"}});
  }
  void send(const std::string& line) override {
    std::string error;
    const auto message = parse_elcano(line, error);
    if (!message) {
      printer_.error(error);
      return;
    }
    elcano::error_code send_error;
    replies_->sent();  // before sending: the reply can come back before `send` returns
    client_->send(*message, send_error);
    const std::string text = format_elcano(*message, generation_);
    if (send_error) {
      replies_->settled();  // nothing will come of it
      printer_.answer({"send failed: " + send_error.message(),
                       {{"text", text}, {"sent", false}, {"error", send_error.message()}}});
    } else {
      printer_.answer({"sent " + text, {{"text", text}, {"sent", true}, {"message", elcano_json(*message)}}});
    }
  }
  bool command(const std::vector<std::string>& words) override {
    if (words.empty() || words[0] != ":capture") return false;
    const std::optional<elcano::TypeSet> set =
        words.size() == 2 ? parse_elcano_types(words[1]) : std::optional<elcano::TypeSet>();
    if (!set) {
      printer_.error(":capture needs TYPES: drive,sensor,goal,segment or none");
    } else {
      client_->set_capture(*set);
      printer_.info("capture", "capturing " + words[1], {{"capture", words[1]}});
    }
    return true;
  }
  void finish(const std::atomic<bool>& stop) override { replies_->wait(stop); }

 private:
  std::shared_ptr<elcano::RingClient> client_;
  ShellPrinter printer_;
  elcano::Generation generation_;
  bool lone_board_;
  bool capture_given_;
  std::shared_ptr<RingReplies> replies_ = std::make_shared<RingReplies>();
};

CodecCommands elcano_commands() {
  CodecCommands row;
  row.name = "elcano";
  row.image_prefixes = {"elcano"};
  row.ring_options = true;
  row.default_options = [](std::uint32_t baud, const DeviceOptions& options) -> devices::CodecOptions {
    elcano::DeviceOptions elcano_options;
    elcano_options.generation = options.generation.value_or(elcano::Generation::b);
    elcano_options.capture = options.capture.value_or(elcano::TypeSet());
    elcano_options.pacing.baud = baud;
    return elcano_options;
  };
  row.lone_virtual_board = [](const std::filesystem::path& firmware, const DeviceOptions& options,
                              devices::DeviceConfig& config) {
    // The host and one board make a ring of one (host TX -> board -> host RX). An unconfigured board
    // captures nothing, so everything would come back undelivered: the board drives the servos from drive
    // messages and answers each with a sensor report (`kLoneVirtualNodeBehaviour`).
    devices::VirtualRingTransport ring;
    devices::RingBoardConfig node;
    node.firmware = firmware;
    devices::RingNodeSettings settings;
    settings.capture = elcano::TypeSet::of(elcano::Type::drive);
    settings.behaviour_bits = kLoneVirtualNodeBehaviour;
    node.eeprom = settings;
    // ... which the host captures (unless --capture says otherwise).
    if (!options.capture) {
      config.options.get<elcano::DeviceOptions>().capture = elcano::TypeSet::of(elcano::Type::sensor);
    }
    ring.boards.push_back(node);
    ring.pacing = transports::Pacing::real_time;
    config.name = firmware.stem().string();
    config.transport = ring;
  };
  row.counters = [](const devices::DeviceClient& client) {
    const elcano::Counters counters = ring_client(client)->counters();
    nlohmann::ordered_json report;
    report["link"] = link_counters_json(counters.link);
    report["ring"] = {{"captured", counters.ring.captured},
                      {"forwarded", counters.ring.forwarded},
                      {"originated", counters.ring.originated},
                      {"undeliverable", counters.ring.undeliverable},
                      {"queue_full_drops", counters.ring.queue_full_drops},
                      {"origins_expired", counters.ring.origins_expired},
                      {"origins_evicted", counters.ring.origins_evicted},
                      {"replies", counters.replies},
                      {"receive_overflows", counters.receive_overflows},
                      {"bytes_written", counters.bytes_written}};
    return report;
  };
  row.shell_help = [](const devices::DeviceConfig&) {
    return std::string(
               "Type a message: D{s 50}{a 25} (drive), S{s 1}{a 2}{b 3}{p 4,5} (sensor), G{n 1}{p 0,0}{b 90} (goal),\n"
               "X{n 1}{p 0,0}{b 90}{s 50} (segment); it is sent into the ring. Captured messages and messages that\n"
               "came back undelivered appear as they arrive. :capture TYPES sets the types the host consumes\n"
               "(drive,sensor,goal,segment or none).\n") +
           kShellCommands;
  };
  row.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig& config,
                      const ShellContext& context) {
    return std::unique_ptr<ShellSession>(std::make_unique<ElcanoShell>(ring_client(client), config, context));
  };
  row.monitor_decoder = make_elcano_monitor_decoder;
  return row;
}

// --- the table --------------------------------------------------------------------------------------------------

struct Table {
  std::mutex mutex;
  std::deque<CodecCommands> rows;  // references stay valid while rows are added
  Table() {
    rows.push_back(romi_commands());
    rows.push_back(proxy_commands("proxy", proxy::Mode::primary));
    rows.push_back(proxy_commands("proxy-compat", proxy::Mode::compat));
    rows.push_back(elcano_commands());
  }
};

Table& table() {
  static Table instance;
  return instance;
}

}  // namespace

const CodecCommands* codec_commands(devices::Codec codec) {
  const std::string_view name = devices::to_string(codec);
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  for (const CodecCommands& row : rows.rows) {
    if (row.name == name) return &row;
  }
  return nullptr;
}

devices::Codec register_codec(devices::CodecRow device, CodecCommands commands) {
  commands.name = device.name;
  const devices::Codec codec = devices::register_codec(std::move(device));
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  rows.rows.push_back(std::move(commands));
  return codec;
}

std::optional<devices::Codec> parse_codec(std::string_view text) {
  if (const devices::CodecRow* row = devices::find_codec(text); row != nullptr && codec_commands(row->codec)) {
    return row->codec;
  }
  return std::nullopt;
}

std::string codec_choices() {
  std::vector<std::string_view> names;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    if (codec_commands(row->codec) != nullptr) names.push_back(row->name);
  }
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) text += i + 1 == names.size() ? " or " : ", ";
    text += names[i];
  }
  return text;
}

devices::Codec codec_of_image(const std::filesystem::path& firmware) {
  const std::string stem = firmware.stem().string();
  devices::Codec codec = devices::Codec::romi;
  std::size_t longest = 0;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr) continue;
    for (const std::string_view prefix : commands->image_prefixes) {
      if (prefix.size() > longest && stem.starts_with(prefix)) {
        longest = prefix.size();
        codec = row->codec;
      }
    }
  }
  return codec;
}

std::unique_ptr<MonitorDecoder> make_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                     Millis now) {
  const CodecCommands* commands = codec_commands(config.codec);
  if (commands == nullptr || !commands->monitor_decoder) return nullptr;
  return commands->monitor_decoder(config, role, now);
}

}  // namespace tether::cli
