// The proxy (and proxy-compat) codec's rows of the `tether` command (tools/tether/codec_commands.hpp): its shell,
// monitor decoder, counters, stats probe and command-line defaults.
#include <nlohmann/json.hpp>

#include <memory>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "device_options.hpp"
#include "proxy_text.hpp"
#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/proxy/plugin.hpp"

namespace tether::cli {

namespace {

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

// What differs between two runs of the same proxy firmware by nature (`tether replay --against-virtual`): the
// sessionId is new at every boot, and ArduinoInfo comes every 5 s of the board's time, so how many there are
// depends on how long each run lasted and where its boot fell.
ReplayFrameView proxy_replay_view(std::span<const std::uint8_t>, const std::vector<MonitorRecord>& decoded) {
  for (const MonitorRecord& record : decoded) {
    if (record.kind != "message") continue;
    const std::string type = record.json.value("type", std::string());
    if (type == "info") return {true, {}, "info: sent every 5 s (how many depends on the run's length)"};
    if (type == "resetEvent") return {false, "resetEvent", "resetEvent: compared without its sessionId (new at every boot)"};
  }
  return {};
}

// The deployed variant's device sends its state stream (a state message per initialised pin or motor, then
// the load cell's) every 50 ms of its time whatever happens: how many there are depends on the run's length.
ReplayFrameView compat_replay_view(std::span<const std::uint8_t>, const std::vector<MonitorRecord>& decoded) {
  for (const MonitorRecord& record : decoded) {
    if (record.kind != "message") continue;
    const std::string type = record.json.value("type", std::string());
    if (type == "servoState" || type == "digitalState" || type == "dcMotorState" || type == "stepperMotorState" ||
        type == "loadCellState") {
      return {true, {}, "state stream (servoState, digitalState, dcMotorState, loadCellState): sent every 50 ms "
                        "(how many depends on the run's length)"};
    }
  }
  return {};
}

CodecCommands proxy_commands(std::string_view name, proxy::Mode mode) {
  CodecCommands row;
  row.name = name;
  row.image_prefixes = {name};
  row.example_image = name;  // the images proxy and proxy-compat
  row.stats_activity =
      mode == proxy::Mode::primary
          ? "the client's session: Reset handshake at the start, a Ping every second, acks\n"
          : "nothing is sent (the deployed protocol has no heartbeat); the device's reports count\n";
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
  if (mode == proxy::Mode::primary) {
    row.replay_frame_view = proxy_replay_view;
    row.replay_rules = "info (ArduinoInfo, every 5 s) ignored; resetEvent compared without its sessionId";
  } else {
    row.replay_frame_view = compat_replay_view;
    row.replay_rules = "the state stream (servoState, digitalState, ..., loadCellState; every 50 ms) ignored";
  }
  return row;
}

}  // namespace

}  // namespace tether::cli

namespace tether::proxy {

/// The command's rows of this codec (collected by tools/tether/CMakeLists.txt: plugin_commands.cpp.in).
std::vector<cli::CodecCommands> command_rows();

std::vector<cli::CodecCommands> command_rows() { return {{cli::proxy_commands("proxy", proxy::Mode::primary), cli::proxy_commands("proxy-compat", proxy::Mode::compat)}}; }

}  // namespace tether::proxy
