// `tether call DEVICE [options] METHOD [FIELD=VALUE ...]` on an rpc device: one call of a method of the
// device's schema, its reply printed as JSON; or a stream method's messages, one JSON object each.
//
// Output contract (scripts rely on it):
//   - stdout: the reply as one JSON object on one line (protobuf's JSON names, every field); a stream: one
//     object per message. With --json: `{"method": ..., "reply": {...}, "message_id": N, "attempts": N}`,
//     `{"method": ..., "seq": N, "message": {...}}` per stream message, `{"method": ..., "error":
//     "device_error" | "refused", "code": N, "text": ...}` for the device's error answer.
//   - stderr: `tether call: METHOD: device error CODE: TEXT` (or `refused CODE: TEXT`), or what failed.
//   - exit status: 0 answered; 1 the device's handler answered an error; 2 usage errors (unknown method or
//     field, bad value, a schema that does not read), a refusal by the device's runtime, a device that
//     cannot be opened (no session, another schema: both hashes named), timeouts and transport errors.
#include <google/protobuf/dynamic_message.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "rpc_text.hpp"
#include "tether/rpc/plugin.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::cli {

namespace {

const CommandText& rpc_call_text() {
  static const CommandText text(
      "call",
      std::string(
          "usage: tether call --port PATH --codec rpc --schema FILE [options] METHOD [FIELD=VALUE ...]\n"
          "       tether call --config FILE --device NAME [options] METHOD [FIELD=VALUE ...]\n"
          "       tether call --virtual FIRMWARE [--schema FILE] [options] METHOD [FIELD=VALUE ...]\n"
          "options: [--timeout MS] [--period MS] [--count N] [--json]\n"
          "\n"
          "Calls one method of an rpc device's schema and prints the reply as one JSON object (protobuf's JSON\n"
          "names, every field). The request is FIELD=VALUE words (the field's name as declared or its JSON\n"
          "name; integers, numbers, true/false, strings, bytes in base64 as the JSON form and the output show\n"
          "them (blob=AQID is 01 02 03), enum values by name or number), or a single argument starting with\n"
          "`{`: the whole request as JSON, for repeated and nested fields:\n"
          "  tether call --port /dev/ttyACM0 --codec rpc --schema arm.proto MoveJoint joint=2 angle_cdeg=-4500\n"
          "  tether call --config rover.json --device arm MoveJoint '{\"joint\": 2, \"angleCdeg\": -4500}'\n"
          "A stream method prints one JSON object per message: `Watch --period 100 --count 5`.\n"
          "\n") +
          device_usage() +
          "\n"
          "  --timeout MS     a call: its whole budget, re-sends included (default 2000, or the configuration's\n"
          "                   call_budget_ms); a stream: the longest wait for its next message (default 2000 +\n"
          "                   3 periods). A serial port that is missing or vanishes before the call is sent is\n"
          "                   waited for within the budget (not with --no-reconnect), and so is the device's\n"
          "                   session (its hello; on a virtual board, on the board's clock); a port that\n"
          "                   vanishes with the call on its way ends it (disconnected: the device may have run it)\n"
          "  --period MS      a stream method's period, 1..65535 (required for one)\n"
          "  --count N        a stream: stop after N messages (default: until Ctrl-C); while its serial port\n"
          "                   is gone the stream waits for it and goes on with the board behind it. The stream\n"
          "                   is closed on the device, its close acknowledged, before the command exits (after\n"
          "                   Ctrl-C for at most 500 ms; unacknowledged: a warning on stderr)\n"
          "  --json           one JSON object per outcome: {\"method\":\"MoveJoint\",\"reply\":{...},\"message_id\":N,\n"
          "                   \"attempts\":N}; a stream's {\"method\":\"Watch\",\"seq\":N,\"message\":{...}}; the\n"
          "                   device's error {\"method\":...,\"error\":\"device_error\",\"code\":42,\"text\":\"...\"}\n"
          "\n"
          "The method and request are checked against the schema before the device is opened, and against the\n"
          "nanopb bounds of the .options file beside it (max_size, max_length, max_count: the field over its bound\n"
          "named). Opening waits for the device's hello: a device built from another schema is refused, both\n"
          "hashes named. --schema without --codec means rpc (a sketch's image: --virtual Sketch.ino.elf --schema F).\n"
          "\n"
          "Exit status: 0 answered; 1 the device answered an error (code and text on stderr and in --json);\n"
          "2 an unknown method or field, a bad value, a schema that does not read or that the device refuses, a\n"
          "refusal by the device's runtime (codes from 0xFF00), a timeout, a transport error, usage errors.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct RpcCallArguments {
  DeviceOptions device;
  std::optional<std::uint32_t> timeout_ms;
  std::optional<std::uint32_t> period_ms;
  std::optional<std::uint32_t> count;
  bool json = false;
  std::vector<std::string> words;  // METHOD and its request
};

std::optional<int> parse_rpc_call(int argc, char** argv, RpcCallArguments& arguments) {
  const CommandText& text = rpc_call_text();
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--") {  // the rest is the method and its request, whatever it looks like
      while (i + 1 < argc) arguments.words.emplace_back(argv[++i]);
      return std::nullopt;
    }
    if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--timeout" || argument == "--period" || argument == "--count") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      const std::uint32_t max = argument == "--timeout" ? 3600000u : argument == "--period" ? 65535u : 0xFFFFFFFFu;
      const auto number = parse_number(value, 1, max);
      if (!number) {
        return text.usage_error(std::string(argument) + " needs a number 1.." + std::to_string(max) + ", got '" +
                                std::string(value) + "'");
      }
      (argument == "--timeout" ? arguments.timeout_ms : argument == "--period" ? arguments.period_ms : arguments.count) =
          *number;
    } else if (argument.size() > 1 && argument.starts_with("-") && arguments.words.empty()) {
      return text.usage_error("unknown option " + std::string(argument));
    } else {
      arguments.words.emplace_back(argument);
    }
    return std::nullopt;
  };
  if (const auto status = parse_device_arguments(argc, argv, text, arguments.device, own)) return status;
  if (arguments.words.empty()) return text.usage_error("no method given");
  return std::nullopt;
}

void print_device_error(bool json, const std::string& method, const rpc::error_code& error,
                        const rpc::DeviceError& answer) {
  const ShellLine line = rpc_device_error_line(method, error, answer);
  if (json) std::printf("%s\n", dump(line.json).c_str());
  cli::out().flush();
  std::fprintf(stderr, "tether call: %s\n", line.text.c_str());
}

// Stops the stream on the device and waits for its ack: a command that exits with the close unsent leaves
// the device streaming until its failsafe (10 s without a ping). After Ctrl-C the wait is short (the
// command ends within a second).
void close_on_device(rpc::Stream& stream, const std::string& name, bool stopping) {
  rpc::error_code error;
  if (stopping) {
    stream.close_and_wait(error, std::chrono::milliseconds(500));
  } else {
    stream.close_and_wait(error);
  }
  if (error) {
    cli::out().flush();
    std::fprintf(stderr,
                 "tether call: %s: warning: the device did not acknowledge the stream's close (%s); it may stream "
                 "until its failsafe (10 s without a ping)\n",
                 name.c_str(), error.message().c_str());
  }
}

// A stream's messages until `count`, its end or a stop signal. While the device's serial port is gone the
// wait for the next message is suspended: the command waits for the port (the client re-opens the stream
// in the board's new session once it is back), and the wait starts again when it is.
int run_rpc_stream(rpc::Client& client, const OpenDevice& device, const rpc::Method& method,
                   const google::protobuf::Message& request, const RpcCallArguments& arguments, Progress& progress) {
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::uint32_t received = 0;
    std::optional<rpc::error_code> ended;
    rpc::DeviceError answer;
    std::chrono::steady_clock::time_point last = std::chrono::steady_clock::now();
  };
  auto state = std::make_shared<State>();
  const bool json = arguments.json;
  const std::uint32_t count = arguments.count.value_or(0);
  const std::string name = method.name;
  rpc::Stream stream;
  try {
    stream = client.open_stream(
        name, request, std::chrono::milliseconds(*arguments.period_ms),
        [state, json, count, name](const rpc::error_code& error, const rpc::StreamMessage& message) {
          std::lock_guard lock(state->mutex);
          if (state->ended || (count != 0 && state->received >= count)) return;
          if (error) {
            state->ended = error;
            state->answer = message.device_error;
          } else {
            const std::string text = rpc_message_json(*message.message);
            out().line(json ? dump({{"method", name}, {"seq", message.seq}, {"message", rpc_message_value(*message.message)}})
                            : text);
            ++state->received;
            state->last = std::chrono::steady_clock::now();
          }
          state->changed.notify_all();
        });
  } catch (const boost::system::system_error& error) {
    return rpc_call_text().fail(name + ": " + error.what());
  }
  const std::atomic<bool>& stop = catch_stop_signals();
  const auto gap = std::chrono::milliseconds(arguments.timeout_ms.value_or(2000 + 3 * *arguments.period_ms));
  const std::shared_ptr<transports::SerialPortStream>& port = device.port();
  bool waiting_for_port = false;
  std::unique_lock lock(state->mutex);
  while (!state->ended && (count == 0 || state->received < count) && !stop) {
    state->changed.wait_for(lock, std::chrono::milliseconds(50));
    if (port && !port->link_counters().up) {
      if (port->link_counters().gave_up) {
        lock.unlock();
        progress.clear();
        stream.close();  // the link failed for good: nothing to tell the device
        return rpc_call_text().fail(name + ": " + port->path() + " vanished and did not come back");
      }
      if (!waiting_for_port) progress.show("waiting for " + port->path() + " to come back...");
      waiting_for_port = true;
      state->last = std::chrono::steady_clock::now();
      continue;
    }
    if (waiting_for_port) progress.clear();
    waiting_for_port = false;
    if (std::chrono::steady_clock::now() - state->last > gap && !state->ended) {
      lock.unlock();
      close_on_device(stream, name, stop);
      return rpc_call_text().fail(name + ": no stream message within " + std::to_string(gap.count()) + " ms");
    }
  }
  const std::optional<rpc::error_code> ended = state->ended;
  const rpc::DeviceError answer = state->answer;
  lock.unlock();
  close_on_device(stream, name, stop);
  if (!ended) return 0;
  if (*ended == rpc::RpcError::device_error || *ended == rpc::RpcError::refused) {
    print_device_error(json, name, *ended, answer);
    return *ended == rpc::RpcError::device_error ? 1 : 2;
  }
  return rpc_call_text().fail(name + ": " + ended->message());
}

}  // namespace

/// `tether generate` (rpc_generate.cpp).
int run_rpc_generate(int argc, char** argv);

// Internal: reached through this plugin's subcommands() only.
static int run_rpc_call(int argc, char** argv) {
  RpcCallArguments arguments;
  if (const auto status = parse_rpc_call(argc, argv, arguments)) return *status;
  const CommandText& text = rpc_call_text();
  std::string error_text;
  auto target = resolve_device(arguments.device, rpc::kCodec, error_text);
  if (!target) return text.usage_error(error_text);
  auto& options = target->config.options.get<rpc::DeviceOptions>();
  if (options.schema.empty()) {
    return text.usage_error("no schema: give --schema FILE (the device's .proto" +
                            std::string(arguments.device.firmware.empty() ? ")" : "; none beside the image)"));
  }
  if (arguments.timeout_ms) options.client.timing.call_budget = *arguments.timeout_ms;
  // Opening waits for the device's session within the call's budget, as it waits for a missing port: a
  // device that never answers fails the command in --timeout, not in the session's own 10 s. A virtual
  // board's client counts on the board's clock, so a loaded machine does not fail its open: its wall-time
  // limit stays the configuration's.
  const std::uint32_t budget_ms = options.client.timing.call_budget;
  options.client.timing.queue_timeout = std::min(options.client.timing.queue_timeout, budget_ms);
  const bool virtual_board = std::holds_alternative<devices::VirtualTransport>(target->config.transport) ||
                             std::holds_alternative<devices::VirtualRingTransport>(target->config.transport);
  if (!virtual_board) options.open_timeout = std::min(options.open_timeout, std::chrono::milliseconds(budget_ms));

  // The method and request, checked against the schema before anything opens.
  std::optional<rpc::Schema> schema;
  try {
    schema.emplace(rpc::load_schema(options, "schema"));
  } catch (const devices::ConfigError& error) {
    return text.fail(error.detail());
  }
  const std::string& name = arguments.words.front();
  const rpc::Method* method = schema->find(name);
  if (method == nullptr) return text.fail(rpc_unknown_method(*schema, name));
  if (method->streaming && !arguments.period_ms) {
    return text.usage_error(name + " is a stream: give --period MS (and --count N to stop after N messages)");
  }
  if (!method->streaming && (arguments.period_ms || arguments.count)) {
    return text.usage_error("--period and --count apply to stream methods (" + name + " is a call)");
  }
  google::protobuf::DynamicMessageFactory factory(&schema->pool());
  std::unique_ptr<google::protobuf::Message> request(factory.GetPrototype(method->input)->New());
  const std::vector<std::string> request_words(arguments.words.begin() + 1, arguments.words.end());
  if (const auto error = fill_rpc_request(*request, request_words)) return text.fail(name + ": " + *error);
  // The device would refuse it as a request that does not decode, without naming the field.
  if (const auto error = RpcBounds(*schema).check(*request)) return text.fail(name + ": " + *error);

  transports::IoThread io;
  Progress progress("call");
  // A serial port that is missing, or vanishes before the call is sent, is waited for within the call's
  // budget (not with --no-reconnect). A call the device may have received when its port vanished is not
  // sent again: it may have run.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(budget_ms);
  auto device = open_device_within(*target, io.executor(), ClientHooks(), progress, deadline, error_text);
  if (!device) {
    // The session's wait was the call's budget: say so, as the wait for a port does.
    const std::string within = "no rpc session within " + std::to_string(budget_ms) + " ms";
    if (const std::size_t at = error_text.find(within); at != std::string::npos) {
      error_text.insert(at + within.size(), " (the call's budget)");
    }
    return text.fail("cannot open " + target->label + ": " + error_text);
  }
  const auto client = device->client_as<rpc::Client>();
  // The client's own request type (its pool): the same fields, so the bytes carry over.
  const auto typed = client->new_request(method->name);
  typed->ParseFromString(request->SerializeAsString());
  int status = 0;
  if (method->streaming) {
    status = run_rpc_stream(*client, *device, *method, *typed, arguments, progress);
  } else {
    rpc::error_code error;
    rpc::CallResult result = client->call(method->name, *typed, error);
    while (error == transports::TransportError::disconnected && result.attempts == 0 &&
           wait_for_port(*device, deadline, progress)) {
      result = client->call(method->name, *typed, error);
    }
    std::string because;
    if (error == transports::TransportError::disconnected) {
      because = result.attempts == 0 ? " (the port was not back within the call's budget, " + std::to_string(budget_ms) + " ms)"
                                     : " (the port vanished with the call on its way: the device may have run it, "
                                       "so it is not sent again)";
    }
    if (!error) {
      const std::string reply = rpc_message_json(*result.reply);
      std::printf("%s\n", arguments.json ? dump({{"method", method->name},
                                                  {"reply", rpc_message_value(*result.reply)},
                                                  {"message_id", result.message_id},
                                                  {"attempts", result.attempts}})
                                                .c_str()
                                          : reply.c_str());
    } else if (error == rpc::RpcError::device_error || error == rpc::RpcError::refused) {
      print_device_error(arguments.json, method->name, error, result.device_error);
      status = error == rpc::RpcError::device_error ? 1 : 2;
    } else {
      if (arguments.json) std::printf("%s\n", dump({{"method", method->name}, {"error", error.message()}}).c_str());
      status = text.fail(method->name + ": " + error.message() + because);
    }
  }
  device->close();
  cli::out().flush();
  return status;
}

}  // namespace tether::cli

namespace tether::rpc {

/// The subcommands this codec adds to `tether` (collected by tools/tether/CMakeLists.txt:
/// plugin_subcommands.cpp.in): its part of `tether call`, for its devices.
std::vector<cli::Command> subcommands();

std::vector<cli::Command> subcommands() {
  return {{"call", cli::run_rpc_call, "rpc: call a method of its schema, the reply as JSON", kCodec},
          {"generate", cli::run_rpc_generate,
           "write an Arduino library from a .proto service: the sketch defines its handlers (rpc codec)"}};
}

}  // namespace tether::rpc
