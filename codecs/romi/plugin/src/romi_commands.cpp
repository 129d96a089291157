// The Romi codec's rows of the `tether` command (tools/tether/codec_commands.hpp): its shell,
// monitor decoder, counters, stats probe and command-line defaults.
#include <nlohmann/json.hpp>

#include <memory>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "device_options.hpp"
#include "romi_text.hpp"
#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/romi/plugin.hpp"

namespace tether::cli {

namespace {

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
  row.example_image = "romi-test";
  row.is_default = true;
  row.stats_activity =
      "the probe command every --interval ms (default '?', every 1000 ms; the first at once);\n"
      "                its answers, errors included, count as traffic; --passive sends nothing\n";
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
  row.probe_usage = "the command sent every interval (default '?')";
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

}  // namespace

}  // namespace tether::cli

namespace tether::romi {

/// The command's rows of this codec (collected by tools/tether/CMakeLists.txt: plugin_commands.cpp.in).
std::vector<cli::CodecCommands> command_rows();

std::vector<cli::CodecCommands> command_rows() { return {{cli::romi_commands()}}; }

}  // namespace tether::romi
