// The rpc codec's rows of the `tether` command (tools/tether/codec_commands.hpp): `--schema`, its shell
// (calls and streams typed as `Method FIELD=VALUE ...`), monitor decoder, counters, stats probe and
// command-line defaults.
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "device_options.hpp"
#include "monitor_decoding.hpp"
#include "rpc_text.hpp"
#include "shell_text.hpp"
#include "tether/rpc/plugin.hpp"

namespace tether::cli {

namespace {

std::shared_ptr<rpc::Client> rpc_client(const devices::DeviceClient& client) { return client.get<rpc::Client>(); }

std::vector<std::string> rpc_words(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> words;
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

// A typed line's request: `Method FIELD=VALUE ...` (or `Method {json}`, the rest of the line); for a stream,
// `period=MS` among the words is its period, `stop` alone closes it.
class RpcShell final : public ShellSession {
 public:
  RpcShell(std::shared_ptr<rpc::Client> client, const ShellContext& context)
      : client_(std::move(client)), bounds_(client_->schema()), printer_(context.printer) {
    const ShellPrinter printer = context.printer;
    const std::function<void()> link_failed = context.link_failed;
    client_->on_event([printer, link_failed](const rpc::Event& event) {
      printer.event(rpc_event_line(event));
      if (std::holds_alternative<rpc::events::LinkFailed>(event)) link_failed();
    });
  }

  void send(const std::string& line) override {
    std::vector<std::string> words = rpc_words(line);
    const std::string name = words.front();
    const rpc::Method* method = client_->schema().find(name);
    if (method == nullptr) {
      printer_.error(rpc_unknown_method(client_->schema(), name));
      return;
    }
    std::vector<std::string> arguments(words.begin() + 1, words.end());
    if (!arguments.empty() && arguments.front().starts_with("{")) {
      arguments = {line.substr(line.find('{'))};  // the request as JSON, its spaces kept
    }
    if (method->streaming) {
      stream(*method, arguments);
    } else {
      call(*method, arguments);
    }
  }

  void finish(const std::atomic<bool>&) override {
    std::map<std::string, rpc::Stream> streams;
    {
      std::lock_guard lock(mutex_);
      streams.swap(streams_);
    }
    // Acked before the client closes, or the device streams on until its failsafe; briefly: the shell
    // ends within a second.
    for (auto& [name, stream] : streams) {
      rpc::error_code error;
      stream.close_and_wait(error, std::chrono::milliseconds(300));
    }
  }

 private:
  void call(const rpc::Method& method, const std::vector<std::string>& arguments) {
    const auto request = client_->new_request(method.name);
    if (const auto error = fill_rpc_request(*request, arguments)) {
      printer_.error(*error);
      return;
    }
    if (const auto error = bounds_.check(*request)) {
      printer_.error(method.name + ": " + *error);
      return;
    }
    rpc::error_code error;
    const rpc::CallResult result = client_->call(method.name, *request, error);
    if (!error) {
      const std::string json = rpc_message_json(*result.reply);
      printer_.answer({method.name + " -> " + json,
                       {{"method", method.name}, {"reply", rpc_message_value(*result.reply)},
                        {"message_id", result.message_id}, {"attempts", result.attempts}}});
    } else if (error == rpc::RpcError::device_error || error == rpc::RpcError::refused) {
      printer_.answer(rpc_device_error_line(method.name, error, result.device_error));
    } else {
      printer_.error(method.name + ": " + error.message());
    }
  }

  void stream(const rpc::Method& method, std::vector<std::string> arguments) {
    if (arguments.size() == 1 && arguments[0] == "stop") {
      std::lock_guard lock(mutex_);
      const bool open = streams_.erase(method.name) > 0;
      printer_.answer({method.name + (open ? " stopped" : " was not streaming"),
                       {{"method", method.name}, {"stopped", open}}});
      return;
    }
    std::optional<std::uint32_t> period;
    std::erase_if(arguments, [&](const std::string& word) {
      if (!word.starts_with("period=")) return false;
      period = parse_number(std::string_view(word).substr(7), 1, 65535);
      if (!period) period = 0;
      return true;
    });
    if (!period || *period == 0) {
      printer_.error(method.name + " streams: give period=MS (1..65535), e.g. `" + method.name +
                     " period=100`; `" + method.name + " stop` stops it");
      return;
    }
    const auto request = client_->new_request(method.name);
    if (const auto error = fill_rpc_request(*request, arguments)) {
      printer_.error(*error);
      return;
    }
    if (const auto error = bounds_.check(*request)) {
      printer_.error(method.name + ": " + *error);
      return;
    }
    const ShellPrinter printer = printer_;
    const std::string name = method.name;
    try {
      rpc::Stream handle = client_->open_stream(
          name, *request, std::chrono::milliseconds(*period),
          [printer, name](const rpc::error_code& error, const rpc::StreamMessage& message) {
            if (!error) {
              const std::string json = rpc_message_json(*message.message);
              printer.event({name + " #" + std::to_string(message.seq) + " " + json,
                             {{"method", name}, {"seq", message.seq}, {"message", rpc_message_value(*message.message)}}});
            } else if (error == rpc::RpcError::device_error || error == rpc::RpcError::refused) {
              printer.event(rpc_device_error_line(name, error, message.device_error));
            } else {
              printer.event({name + " ended: " + error.message(), {{"method", name}, {"ended", error.message()}}});
            }
          });
      std::lock_guard lock(mutex_);
      streams_[name] = std::move(handle);
    } catch (const boost::system::system_error& error) {
      printer_.error(name + ": " + error.what());
      return;
    }
    printer_.answer({name + " streaming every " + std::to_string(*period) + " ms (`" + name + " stop` stops it)",
                     {{"method", name}, {"period_ms", *period}, {"streaming", true}}});
  }

  std::shared_ptr<rpc::Client> client_;
  const RpcBounds bounds_;  // the schema's .options, read once
  ShellPrinter printer_;
  std::mutex mutex_;
  std::map<std::string, rpc::Stream> streams_;
};

// What differs between two runs of the same rpc firmware by nature (`tether replay --against-virtual`): the
// session the device draws at every boot, in its reset-event and its hello.
ReplayFrameView rpc_replay_view(std::span<const std::uint8_t>, const std::vector<MonitorRecord>& decoded) {
  for (const MonitorRecord& record : decoded) {
    if (record.kind != "message" || !record.json.contains("session")) continue;
    nlohmann::ordered_json rest = record.json;
    rest.erase("session");
    return {false, dump(rest), record.json.value("message", std::string()) +
                                   ": compared without its session (new at every boot)"};
  }
  return {};
}

CodecCommands rpc_commands() {
  CodecCommands row;
  row.name = "rpc";
  row.image_prefixes = {"rpc"};
  row.example_image = "rpc-example";
  row.stats_activity =
      "the client's session: Hello handshake, a Ping every second; with --probe\n"
      "                'METHOD FIELD=VALUE ...' that call every --interval ms (default: no call)\n";
  row.flags = {{"--schema",
                "    --schema FILE    the device's .proto (its service; the device's Hello must carry its hash);\n"
                "                     with --virtual IMAGE, IMAGE.proto beside the image when not given;\n"
                "                     without --codec it makes the codec rpc (unless the image's name says one)\n",
                [](std::string_view value) -> std::optional<std::string> {
                  if (value.empty()) return std::string("a .proto file");
                  return std::nullopt;
                }}};
  row.default_options = [](std::uint32_t baud, const DeviceOptions& given) -> devices::CodecOptions {
    rpc::DeviceOptions options;
    options.client.timing.baud = baud;
    if (const std::string* schema = given.codec_flag("--schema")) options.schema = *schema;
    if (!options.schema.empty()) {
      try {
        (void)rpc::load_schema(options, "");  // its error is a usage error, about the flag
      } catch (const devices::ConfigError& failure) {
        throw devices::ConfigError("--schema", failure.detail(), failure.code());
      }
    }
    return options;
  };
  // A lone board: the schema beside its image (`rpc-example.elf`, `rpc-example.proto`), if there is one,
  // unless --schema names one.
  row.lone_virtual_board = [](const std::filesystem::path& firmware, const DeviceOptions&, devices::DeviceConfig& config) {
    devices::VirtualTransport board;
    board.board.firmware = firmware;
    board.board.pacing = transports::Pacing::real_time;
    board.board.name = firmware.stem().string();
    config.name = board.board.name;
    config.transport = board;
    auto& options = config.options.get<rpc::DeviceOptions>();
    const std::filesystem::path beside = std::filesystem::path(firmware).replace_extension(".proto");
    std::error_code error;
    if (options.schema.empty() && std::filesystem::is_regular_file(beside, error)) options.schema = beside;
  };
  row.readying = "waiting for the device's hello with this schema...";
  row.counters = [](const devices::DeviceClient& device_client) {
    const auto client = rpc_client(device_client);
    const rpc::Counters counters = client->counters();
    nlohmann::ordered_json report;
    report["link"] = link_counters_json(counters.link);
    report["rpc"] = {{"messages_sent", counters.messages_sent},
                     {"replies", counters.replies},
                     {"device_errors", counters.device_errors},
                     {"refusals", counters.refusals},
                     {"stream_messages", counters.stream_messages},
                     {"stale_stream_messages", counters.stale_stream_messages},
                     {"pings_sent", counters.pings_sent},
                     {"hellos_sent", counters.hellos_sent},
                     {"undecodable", counters.undecodable}};
    const rpc::SessionStatus session = client->session();
    report["session"] = {{"established", session.established}, {"session_id", nullptr},
                         {"schema_hash", rpc::format_hash(client->schema().hash())}};
    if (session.session_id) report["session"]["session_id"] = *session.session_id;
    return report;
  };
  row.shell_help = [](const devices::DeviceConfig& config) {
    std::string methods;
    if (const auto schema = rpc_config_schema(config)) methods = rpc_method_list(*schema, "  ");
    return "Type a method and its request's fields (FIELD=VALUE, bytes in base64; or the request as one JSON\n"
           "object):\n" + methods +
           "A call prints its reply as JSON (or the device's error code and text). A stream method starts with\n"
           "period=MS among its fields (`Watch period=100`), prints each message as it arrives, and stops with\n"
           "`Watch stop` (and at the end of input). Session changes and resets appear as they happen.\n" +
           kShellCommands;
  };
  row.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig&, const ShellContext& context) {
    return std::unique_ptr<ShellSession>(std::make_unique<RpcShell>(rpc_client(client), context));
  };
  row.replay_frame_view = rpc_replay_view;
  row.replay_rules = "reset-event and device-hello compared without their session";
  row.monitor_decoder = [](const devices::DeviceConfig& config, const DecoderRole& role, Millis) {
    return make_rpc_monitor_decoder(rpc_config_schema(config), role);
  };
  // The probe: one call `METHOD FIELD=VALUE ...` every interval; none by default (the session's pings).
  row.default_probe = "";
  row.probe_usage = "a call, 'METHOD FIELD=VALUE'";
  row.check_probe = [](const std::string& probe) -> std::optional<std::string> {
    if (!probe.empty() && (probe.front() == ' ' || probe.find('=') == 0)) return std::string("expected METHOD FIELD=VALUE ...");
    return std::nullopt;
  };
  row.send_probe = [](const devices::DeviceClient& device_client, const std::string& probe) {
    const auto client = rpc_client(device_client);
    if (probe.empty()) return client->session().established;
    const std::vector<std::string> words = rpc_words(probe);
    const rpc::Method* method = client->schema().find(words.front());
    if (method == nullptr || method->streaming) return false;
    const auto request = client->new_request(method->name);
    if (fill_rpc_request(*request, std::vector<std::string>(words.begin() + 1, words.end()))) return false;
    rpc::error_code error;
    (void)client->call(method->name, *request, error);
    return !error;
  };
  return row;
}

}  // namespace

}  // namespace tether::cli

namespace tether::rpc {

/// The command's rows of this codec (collected by tools/tether/CMakeLists.txt: plugin_commands.cpp.in).
std::vector<cli::CodecCommands> command_rows();

std::vector<cli::CodecCommands> command_rows() { return {cli::rpc_commands()}; }

}  // namespace tether::rpc
