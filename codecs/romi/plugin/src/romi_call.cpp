// `tether call DEVICE [options] 'COMMAND'`: sends one Romi command to a device and prints its answer.
//
// Output contract (scripts rely on it):
//   - stdout: the device's answer array as compact JSON on one line (`[0,1,2]`), only when the device
//     answered; with --json instead one JSON object for every outcome (see the usage text).
//   - stderr: `tether call: <code> <message>` when the code is not 0 (the message is the client's, e.g.
//     what timed out), and `log: <text>` for each log line the device sent during the call.
//   - exit status: 0 code 0; 1 application error (code > 0); 2 protocol error (code < 0, from the device or
//     the host: rejected command, timeout, transport), usage errors and a device that cannot be opened.
//
// The device is named like every device subcommand's (device_options.hpp): --port, --config/--device
// (serial, TCP or virtual transports), --virtual. Every run is a new host session. Starting each at id 0
// would make two runs of the same command look like one request sent twice to a device that filters repeated
// ids (reference firmware: -15 duplicate; Tether firmware: the cached answer, without running the command
// again). So the id is random unless --id (or the configuration's first_id) says.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "romi_text.hpp"
#include "tether/romi/client.hpp"
#include "tether/romi/plugin.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::cli {

namespace {

const CommandText& romi_call_command() {
  static const CommandText text(
      "call",
      std::string(
          "usage: tether call --port PATH [--baud N] [--boot-wait MS] [options] 'COMMAND'\n"
          "       tether call --config FILE --device NAME [options] 'COMMAND'\n"
          "       tether call --virtual FIRMWARE [options] 'COMMAND'\n"
          "options: [--timeout MS] [--id N] [--manual] [--json]\n"
          "\n"
          "Sends one Romi command to the device and prints the answer array as JSON on stdout. Commands\n"
          "are the device's own; on the romi-test image: 'e' -> [0,1,2], 's[2,3]' -> [0,5],\n"
          "'t[\"hello\"]' -> [0,\"hello\"], 'f' -> [101,\"I will try again tomorrow\"] (exit status 1).\n"
          "Try it: `tether call --virtual romi-test e`.\n"
          "\n") +
          device_usage() +
          "  (another codec's device: its own calls, `tether call --codec CODEC --help`, if it has them)\n"
          "\n"
          "  --timeout MS     total time of the call, retries and log lines included (default 2000, the spec's\n"
          "                   budget; with --config, the configuration's); each attempt waits at most\n"
          "                   min(MS, 1000) for the answer. A serial port that is missing or vanishes before\n"
          "                   the call is sent is waited for that long (not with --no-reconnect); one that\n"
          "                   vanishes with the call on its way ends it (-33 disconnected: it may have run)\n"
          "  --id N           request id 0..255 (default: random, never 255; with --config, its first_id if\n"
          "                   set). Each run is a new session: a fixed id would make two runs of one command\n"
          "                   look like a repeated request to a device that filters repeated ids (it would\n"
          "                   answer -15, or its cached answer without running the command again)\n"
          "  --manual         send the terminal form `#COMMAND:xxxx` (no id, no CRC; the answer carries id 00)\n"
          "  --json           print one JSON object for every outcome instead of the bare array:\n"
          "                   {\"code\":0,\"message\":\"\",\"values\":[0,1,2],\"answered\":true,\"id\":7,\"attempts\":1,\n"
          "                   \"raw\":\"e[0,1,2]\"} (raw: the answer as received, only when there was one)\n"
          "\n"
          "The command is checked before anything is opened (opcode [a-zA-Z0-9?], at most 12 int16 values and\n"
          "one string of at most 32 characters, frame <= 64 bytes). Log lines the device sends during the call\n"
          "are printed on stderr as `log: TEXT`. Errors are printed on stderr as `tether call: CODE MESSAGE`,\n"
          "with the client's message (e.g. which deadline passed without an answer).\n"
          "\n"
          "Exit status: 0 the device answered code 0; 1 it answered an application error (code > 0);\n"
          "2 a protocol or transport error (code < 0: the device's, or the host's such as -25 no answer in\n"
          "time, -10 value out of range, -33 transport error), usage errors and a device that cannot be opened.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct RomiCallArguments {
  DeviceOptions device;
  std::optional<std::uint32_t> timeout_ms;
  std::optional<std::uint8_t> id;
  bool manual = false;
  bool json = false;
  std::optional<std::string> command;
};

// Returns an exit status if parsing ends the program (help or error).
std::optional<int> parse_romi_call_arguments(int argc, char** argv, RomiCallArguments& arguments) {
  const CommandText& text = romi_call_command();
  const auto take_command = [&](std::string_view argument) -> std::optional<int> {
    if (arguments.command) {
      return text.usage_error("more than one command given (quote the command: 'M[16,\"Shutdown\"]')");
    }
    arguments.command = std::string(argument);
    return std::nullopt;
  };
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--") {  // the next argument is the command, whatever it looks like
      if (i + 1 >= argc) return text.usage_error("-- needs the command after it");
      return take_command(argv[++i]);
    }
    if (argument == "--manual") {
      arguments.manual = true;
    } else if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--timeout" || argument == "--id") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--timeout") {
        arguments.timeout_ms = parse_number(value, 1, 3600000);
        if (!arguments.timeout_ms) {
          return text.usage_error("--timeout needs milliseconds (1..3600000), got '" + std::string(value) + "'");
        }
      } else {
        const auto id = parse_number(value, 0, 255);
        if (!id) return text.usage_error("--id needs a number 0..255, got '" + std::string(value) + "'");
        arguments.id = static_cast<std::uint8_t>(*id);
      }
    } else if (argument.size() > 1 && argument.starts_with("-")) {
      return text.usage_error("unknown option " + std::string(argument));
    } else {
      return take_command(argument);
    }
    return std::nullopt;
  };
  if (const auto status = parse_device_arguments(argc, argv, text, arguments.device, own)) return status;
  if (!arguments.command) return text.usage_error("no command given");
  return std::nullopt;
}

}  // namespace

// Internal: reached through this plugin's subcommands() only.
static int run_call(int argc, char** argv) {
  RomiCallArguments arguments;
  if (const auto status = parse_romi_call_arguments(argc, argv, arguments)) return *status;
  std::string error_text;
  auto target = resolve_device(arguments.device, romi::kCodec, error_text);
  if (!target) return romi_call_command().usage_error(error_text);
  if (target->config.codec != romi::kCodec) {
    return romi_call_command().usage_error(target->label + " speaks " +
                                      std::string(devices::to_string(target->config.codec)) +
                                      ", not romi (`tether send`, `shell` or `monitor` talk to it)");
  }
  auto& romi_options = target->config.options.get<romi::DeviceOptions>();
  if (arguments.timeout_ms) {
    romi_options.timing.call_budget = *arguments.timeout_ms;
    romi_options.timing.attempt_timeout = std::min<std::uint32_t>(*arguments.timeout_ms, romi::kControllerDeadlineMs);
  }
  if (arguments.id) romi_options.first_id = *arguments.id;

  // Reject a bad command before touching the device.
  const romi::Command command(*arguments.command);
  romi::RomiResponse response;
  boost::system::error_code error;
  if (!command.valid()) {
    error = command.error();
    response = romi::failed_response(command);  // what the client would complete with
  } else {
    transports::IoThread io;
    Progress progress("call");
    ClientHooks hooks;
    hooks.on_client = [](const devices::DeviceClient& client) {
      client.get<romi::Client>()->on_event([](const romi::Event& event) {
        if (const auto* log = std::get_if<romi::events::Log>(&event)) {
          std::fprintf(stderr, "%s\n", romi_log_line(log->text).text.c_str());  // the shell's form
        }
      });
    };
    // A serial port that is missing, or vanishes before the call is sent, is waited for within the call's
    // budget (not with --no-reconnect). A call the device may have received when its port vanished is not
    // sent again: it may have run.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(romi_options.timing.call_budget);
    auto device = open_device_within(*target, io.executor(), hooks, progress, deadline, error_text);
    if (!device) return romi_call_command().fail("cannot open " + error_text + " (" + target->label + ")");
    const auto client = device->client_as<romi::Client>();
    const auto call = [&] {
      response = arguments.manual ? client->call_manual(command, error) : client->call(command, error);
    };
    call();
    while (error == transports::TransportError::disconnected && response.attempts == 0 &&
           wait_for_port(*device, deadline, progress)) {
      call();
    }
    if (error == transports::TransportError::disconnected) {
      response.message += response.attempts == 0
                              ? ": the port was not back within the call's budget (" +
                                    std::to_string(romi_options.timing.call_budget) + " ms)"
                              : ": the port vanished with the call on its way (the device may have run it: not sent "
                                "again)";
    }
    device->close();
  }

  if (arguments.json) {
    nlohmann::ordered_json object = {{"code", response.code},     {"message", response.message},
                                     {"values", response.values}, {"answered", response.answered},
                                     {"id", response.id},         {"attempts", response.attempts}};
    if (!response.raw.empty()) object["raw"] = response.raw;
    std::printf("%s\n", dump(object).c_str());
  } else if (response.answered) {
    std::printf("%s\n", dump(response.values).c_str());
  }
  cli::out().flush();
  if (response.code != 0) {
    std::string line = std::to_string(response.code) + " " + printable(response.message);
    if (response.unreadable_answer()) {
      line += " (received: " + printable(response.raw) + ")";
    }
    std::fprintf(stderr, "tether call: %s\n", line.c_str());
  }
  if (error || response.code < 0) return 2;
  return response.code > 0 ? 1 : 0;
}

}  // namespace tether::cli

namespace tether::romi {

/// The subcommands this codec adds to `tether` (collected by tools/tether/CMakeLists.txt:
/// plugin_subcommands.cpp.in): its part of `tether call`, for its devices.
std::vector<cli::Command> subcommands();

std::vector<cli::Command> subcommands() {
  return {{"call", cli::run_call, "send one Romi command to a device (serial port or pty) and print its answer as JSON",
           kCodec}};
}

}  // namespace tether::romi
