// `tether call --port PATH [options] 'COMMAND'`: sends one Romi command to a device and prints its answer.
//
// Output contract (scripts rely on it):
//   - stdout: the device's answer array as compact JSON on one line (`[0,1,2]`), only when the device
//     answered; with --json instead one JSON object for every outcome (see kUsage).
//   - stderr: `tether call: <code> <message>` when the code is not 0, and `log: <text>` for each log line
//     the device sent during the call.
//   - exit status: 0 code 0; 1 application error (code > 0); 2 protocol error (code < 0, from the device or
//     the host: rejected command, timeout, transport), and usage or setup errors.
//
// Every run is a new host session. Starting each at id 0 would make two runs of the same command look like
// one request sent twice to a device that filters repeated ids (reference firmware: -15 duplicate; Tether
// firmware: the cached answer, without running the command again). So the id is random unless --id says.

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

#include "cli_support.hpp"
#include "commands.hpp"
#include "tether/romi/client.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/serial_port_stream.hpp"

namespace tether::cli {

namespace {

namespace asio = boost::asio;

const CommandText& command_text() {
  static const CommandText text(
      "call",
      "usage: tether call --port PATH [--baud N] [--timeout MS] [--boot-wait MS] [--id N] [--manual] [--json]\n"
      "                   'COMMAND'\n"
      "\n"
      "Sends one Romi command (e.g. 'L[1]', 'M[16,\"Shutdown\"]') to the device on PATH (a serial port or a\n"
      "pty, e.g. the one `tether sim` prints) and prints the answer array as JSON on stdout.\n"
      "\n"
      "  --port PATH      serial device or pty (required)\n"
      "  --baud N         line speed (default 115200)\n"
      "  --timeout MS     total time of the call, retries and log lines included (default 2000, the spec's\n"
      "                   budget); each attempt waits at most min(MS, 1000) for the answer\n"
      "  --boot-wait MS   wait after opening the port and drop what the board printed meanwhile (default 0;\n"
      "                   use 2000 for an Arduino Uno, which resets when the port opens)\n"
      "  --id N           request id 0..255 (default: random, never 255). Each run is a new session: a fixed\n"
      "                   id would make two runs of one command look like a repeated request to a device\n"
      "                   that filters repeated ids (it would answer -15, or its cached answer without\n"
      "                   running the command again)\n"
      "  --manual         send the terminal form `#COMMAND:xxxx` (no id, no CRC; the answer carries id 00)\n"
      "  --json           print one JSON object for every outcome instead of the bare array:\n"
      "                   {\"code\":0,\"message\":\"\",\"values\":[0,1,2],\"answered\":true,\"id\":7,\"attempts\":1,\n"
      "                   \"raw\":\"e[0,1,2]\"} (raw: the answer as received, only when there was one)\n"
      "\n"
      "The command is checked before anything is sent (opcode [a-zA-Z0-9?], at most 12 int16 values and one\n"
      "string of at most 32 characters, frame <= 64 bytes). Log lines the device sends during the call are\n"
      "printed on stderr as `log: TEXT`. Errors are printed on stderr as `tether call: CODE MESSAGE`.\n"
      "\n"
      "Exit status: 0 the device answered code 0; 1 it answered an application error (code > 0);\n"
      "2 a protocol or transport error (code < 0: the device's, or the host's such as -25 timed out,\n"
      "-10 value out of range, -33 transport error) and usage errors.\n");
  return text;
}

struct Arguments {
  std::string port;
  unsigned baud = 115200;
  std::uint32_t timeout_ms = romi::kHostCallBudgetMs;
  std::uint32_t boot_wait_ms = 0;
  std::optional<std::uint8_t> id;
  bool manual = false;
  bool json = false;
  std::optional<std::string> command;
};

// Returns an exit status if parsing ends the program (help or error).
std::optional<int> parse(int argc, char** argv, Arguments& arguments) {
  const CommandText& text = command_text();
  bool options_done = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view argument = argv[i];
    if (!options_done && (argument == "--help" || argument == "-h")) return text.help();
    if (!options_done && argument == "--") {
      options_done = true;
    } else if (!options_done && argument == "--manual") {
      arguments.manual = true;
    } else if (!options_done && argument == "--json") {
      arguments.json = true;
    } else if (!options_done && (argument == "--port" || argument == "--baud" || argument == "--timeout" ||
                                 argument == "--boot-wait" || argument == "--id")) {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--port") {
        if (value.empty()) return text.usage_error("--port needs a path");
        arguments.port = std::string(value);
      } else if (argument == "--baud") {
        const auto baud = parse_number(value, 1, 4000000);
        if (!baud) return text.usage_error("--baud needs a positive number, got '" + std::string(value) + "'");
        arguments.baud = *baud;
      } else if (argument == "--timeout") {
        const auto timeout = parse_number(value, 1, 3600000);
        if (!timeout) {
          return text.usage_error("--timeout needs milliseconds (1..3600000), got '" + std::string(value) + "'");
        }
        arguments.timeout_ms = *timeout;
      } else if (argument == "--id") {
        const auto id = parse_number(value, 0, 255);
        if (!id) return text.usage_error("--id needs a number 0..255, got '" + std::string(value) + "'");
        arguments.id = static_cast<std::uint8_t>(*id);
      } else {
        const auto wait = parse_number(value, 0, 60000);
        if (!wait) {
          return text.usage_error("--boot-wait needs milliseconds (0..60000), got '" + std::string(value) + "'");
        }
        arguments.boot_wait_ms = *wait;
      }
    } else if (!options_done && argument.size() > 1 && argument.starts_with("--")) {
      return text.usage_error("unknown option " + std::string(argument));
    } else if (arguments.command) {
      return text.usage_error("more than one command given (quote the command: 'M[16,\"Shutdown\"]')");
    } else {
      arguments.command = std::string(argument);
    }
  }
  if (arguments.port.empty()) return text.usage_error("--port is required");
  if (!arguments.command) return text.usage_error("no command given");
  return std::nullopt;
}


template <typename Json>
std::string dump(const Json& value) {
  return value.dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace

int run_call(int argc, char** argv) {
  Arguments arguments;
  if (const auto status = parse(argc, argv, arguments)) return *status;

  // Reject a bad command before touching the port.
  const romi::Command command(*arguments.command);
  romi::RomiResponse response;
  boost::system::error_code error;
  if (!command.valid()) {
    error = command.error();
    response.code = static_cast<std::int16_t>(error.value());
    response.message = error.message();
    response.values = nlohmann::json::array({response.code, response.message});
    response.opcode = command.opcode();
  } else {
    tether::transports::IoThread io;
    transports::SerialOptions options;
    options.baud = arguments.baud;
    options.boot_wait = std::chrono::milliseconds(arguments.boot_wait_ms);
    auto port = transports::SerialPortStream::open(io.executor(), arguments.port, options, error);
    if (!port) return command_text().fail("cannot open " + arguments.port + ": " + error.message());
    romi::ClientOptions client_options;
    client_options.first_id(arguments.id ? *arguments.id : romi::random_first_id());
    client_options.timing.call_budget = arguments.timeout_ms;
    client_options.timing.attempt_timeout = std::min<std::uint32_t>(arguments.timeout_ms, romi::kControllerDeadlineMs);
    romi::RomiClient client(port, client_options);
    client.set_log_handler([](std::string_view text) {
      std::fprintf(stderr, "log: %.*s\n", static_cast<int>(text.size()), text.data());
    });
    response = arguments.manual ? client.call_manual(command, error) : client.call(command, error);
    client.close();
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
  std::fflush(stdout);
  if (response.code != 0) {
    std::string line = std::to_string(response.code) + " " + response.message;
    if (response.answered && (response.code == -23 || response.code == -26 || response.code == -27)) {
      line += " (received: " + response.raw + ")";
    }
    std::fprintf(stderr, "tether call: %s\n", line.c_str());
  }
  if (error || response.code < 0) return 2;
  return response.code > 0 ? 1 : 0;
}

}  // namespace tether::cli
