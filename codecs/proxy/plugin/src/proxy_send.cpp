// `tether send DEVICE MESSAGE [FIELD=VALUE ...] [MESSAGE ...]`: sends proxy messages by name and prints
// what became of each.
//
// Output contract: one line per message on stdout (`servo-control: acked, message id 7, 1 attempt; pin 9
// = 120`), with --json one JSON object per message and line instead; errors on stderr as
// `tether send: ...`. Exit status: 0 every message acked (compat: written) and no device error reported
// for it; 1 the device reported an error for one or acked it as refused (e.g. `pin 5 not initialised`); 2 usage errors, a device
// that cannot be opened, a send that failed (timed out, link failure).
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "proxy_text.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::cli {

namespace {

const CommandText& proxy_send_command() {
  static const CommandText text(
      "send",
      std::string(
          "usage: tether send DEVICE [--timeout MS] [--settle MS] [--json] MESSAGE [FIELD=VALUE ...] [MESSAGE ...]\n"
          "\n"
          "Sends proxy messages (codec proxy or proxy-compat) to a device, one after the other, and prints what\n"
          "became of each. A word without '=' starts a message, the FIELD=VALUE words after it are its fields:\n"
          "  tether send --virtual proxy servo-init pin=9 safe-position=90 servo-control pin=9 position=120\n"
          "Names are the schema's in kebab-case (codecs/proxy/proto/*.proto); fields may also be written in\n"
          "camelCase or snake_case. Every field must be given; booleans are true/false, 1/0, on/off, high/low.\n"
          "Primary mode (proxy), messages the host sends (messageId is assigned by the client):\n") +
      proxy_message_list(proxy::Mode::primary, "  ") +
      "Compatibility mode (proxy-compat, the deployed RocketryProto schema):\n" +
      proxy_message_list(proxy::Mode::compat, "  ") +
      "\n"
      "Every run is a new session: in primary mode the client resets the device when it opens (Reset, then\n"
      "ResetEvent), so pins must be initialised in the same run (or by the configuration's inits, --config).\n"
      "`reset` restarts the session (Reset, ResetEvent, inits replayed). In compatibility mode a message is\n"
      "done when written; the device's answer (its EventMessage or ErrorMessage) is awaited for --settle ms.\n"
      "Servo positions are degrees 0..180 in both modes (others are usage errors). A compat device ignores\n"
      "an init of a pin it already has, silently, as the deployed firmware does: no answer comes.\n"
      "\n" +
      device_usage("proxy") +
      "  (send speaks the proxy protocol: proxy or proxy-compat devices)\n"
      "\n"
      "  --timeout MS   primary mode: time from a message's first send to its ack, re-sends included\n"
      "                 (default 1000)\n"
      "  --settle MS    compatibility mode: how long to wait for the device's answer to each message\n"
      "                 (default 500)\n"
      "  --json         one JSON object per message and line: {\"message\":\"servo-control\",\"acked\":true,\n"
      "                 \"written\":true,\"message_id\":7,\"attempts\":1,\"error\":null,\"device_errors\":[],\n"
      "                 \"pin_state\":{\"pin\":9,\"value\":120,\"failsafe\":false}} (pin_state: the device's report\n"
      "                 of the message's pin, when one came with the ack; reset: \"session_id\"; compat:\n"
      "                 \"device_events\" [\"SERVO_INIT 9\"] (the events answering this message),\n"
      "                 \"other_device_events\" (others meanwhile, e.g. a boot's RESET) and \"device_answered\")\n"
      "\n"
      "Exit status: 0 every message acked (compat: written) without a device error; 1 the device reported\n"
      "an error for a message (Error / ErrorMessage, e.g. an uninitialised pin); 2 usage errors, a device\n"
      "that cannot be opened, a send that failed (timed out, link failure).\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct ProxySendArguments {
  DeviceOptions device;
  std::optional<std::uint32_t> timeout_ms;
  std::uint32_t settle_ms = 500;
  bool json = false;
  std::vector<std::string> words;
};

std::optional<int> parse_proxy_send_arguments(int argc, char** argv, ProxySendArguments& arguments) {
  const CommandText& text = proxy_send_command();
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--timeout" || argument == "--settle") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      const auto ms = parse_number(value, argument == "--timeout" ? 1 : 0, 3600000);
      if (!ms) return text.usage_error(std::string(argument) + " needs milliseconds, got '" + std::string(value) + "'");
      if (argument == "--timeout") {
        arguments.timeout_ms = *ms;
      } else {
        arguments.settle_ms = *ms;
      }
    } else if (argument.starts_with("--")) {
      return text.usage_error("unknown option " + std::string(argument));
    } else {
      arguments.words.emplace_back(argument);
    }
    return std::nullopt;
  };
  if (const auto status = parse_device_arguments(argc, argv, text, arguments.device, own)) return status;
  if (arguments.words.empty()) return text.usage_error("no message given");
  return std::nullopt;
}

// What the device said while one message was on its way.
struct Observed {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::string> device_errors;
  std::vector<proxy::events::PinReport> pin_reports;
  std::vector<std::string> compat_events;  // the EventMessages that answer the message being sent
  std::vector<std::string> other_events;   // the others meanwhile (a boot's RESET, an init replayed on it)
  std::string compat_expected;  // the EventMessage type that answers the message being sent (compat)
  std::optional<std::uint32_t> compat_pin;  // and its data, for messages with a pin
  std::size_t compat_answers = 0;
  std::size_t sessions = 0;
  std::uint32_t session_id = 0;
  std::optional<std::string> link_error;

  void clear() {
    const std::lock_guard lock(mutex);
    device_errors.clear();
    pin_reports.clear();
    compat_events.clear();
    other_events.clear();
    compat_answers = 0;
    compat_expected.clear();
    compat_pin.reset();
  }
};

void observe(Observed& observed, const proxy::Event& event) {
  const std::lock_guard lock(observed.mutex);
  if (const auto* error = std::get_if<proxy::events::DeviceError>(&event)) {
    observed.device_errors.push_back(error->text);
  } else if (const auto* report = std::get_if<proxy::events::PinReport>(&event)) {
    observed.pin_reports.push_back(*report);
  } else if (const auto* established = std::get_if<proxy::events::SessionEstablished>(&event)) {
    ++observed.sessions;
    observed.session_id = established->session_id;
  } else if (const auto* compat = std::get_if<proxy::events::CompatEvent>(&event)) {
    const std::string name = RocketryProto::EventTypes_Name(compat->type);
    // Only the event of this message's type and pin answers it; others (the boot announcement RESET, the
    // SERVO_INIT of an init the client replays on it) are listed apart, never under this message.
    const bool answer = observed.compat_expected.empty() ||
                        (name == observed.compat_expected &&
                         (!observed.compat_pin || compat->data == static_cast<std::int32_t>(*observed.compat_pin)));
    (answer ? observed.compat_events : observed.other_events).push_back(name + " " + std::to_string(compat->data));
    if (answer) ++observed.compat_answers;
  } else if (const auto* compat_error = std::get_if<proxy::events::CompatError>(&event)) {
    observed.device_errors.push_back(RocketryProto::ErrorTypes_Name(compat_error->type) + " " +
                                     std::to_string(compat_error->data));
    ++observed.compat_answers;
  } else if (const auto* failed = std::get_if<proxy::events::LinkFailed>(&event)) {
    observed.link_error = failed->error.message();
  }
  observed.changed.notify_all();
}

std::string plural(std::uint32_t count, const char* word) {
  return std::to_string(count) + " " + word + (count == 1 ? "" : "s");
}

}  // namespace

// Internal: reached through this plugin's subcommands() only.
static int run_send(int argc, char** argv) {
  ProxySendArguments arguments;
  if (const auto status = parse_proxy_send_arguments(argc, argv, arguments)) return *status;
  std::string error;
  auto target = resolve_device(arguments.device, proxy::kCodec, error);
  if (!target) return proxy_send_command().usage_error(error);
  if (target->config.codec != proxy::kCodec && target->config.codec != proxy::kCompatCodec) {
    const devices::Codec codec = target->config.codec;
    return proxy_send_command().usage_error(target->label + " speaks " + std::string(devices::to_string(codec)) +
                                      ", not the proxy protocol (`tether shell` and `monitor` talk to it)");
  }
  auto& proxy_options = target->config.options.get<proxy::DeviceOptions>();
  const proxy::Mode mode = proxy_options.client.mode;
  if (arguments.timeout_ms) proxy_options.client.timing.send_budget = *arguments.timeout_ms;

  // Every message is checked before the device is touched.
  std::vector<ProxyCommand> commands;
  for (std::size_t start = 0; start < arguments.words.size();) {
    std::size_t end = start + 1;
    while (end < arguments.words.size() && arguments.words[end].find('=') != std::string::npos) ++end;
    auto command = parse_proxy_command(mode, std::span(arguments.words).subspan(start, end - start), error);
    if (!command) return proxy_send_command().usage_error(error);
    commands.push_back(std::move(*command));
    start = end;
  }

  transports::IoThread io;
  Progress progress("send");
  // Shared with the event handler, which may still run on the I/O thread while this function returns.
  const auto seen = std::make_shared<Observed>();
  ClientHooks hooks;
  hooks.on_client = [seen](const devices::DeviceClient& client) {
    client.get<proxy::Client>()->on_event([seen](const proxy::Event& event) { observe(*seen, event); });
  };
  auto device = open_device(*target, io.executor(), hooks, progress, error);
  if (!device) return proxy_send_command().fail(target->label + ": " + error);
  proxy::Client& client = *device->client_as<proxy::Client>();

  int status = 0;
  for (const ProxyCommand& command : commands) {
    seen->clear();
    {
      // Compat: the device answers `servo-init` with EventMessage SERVO_INIT, and so on (or an ErrorMessage).
      std::string expected;
      for (const char c : command.name)
        expected += c == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      RocketryProto::EventTypes type{};
      const std::lock_guard lock(seen->mutex);
      if (RocketryProto::EventTypes_Parse(expected, &type)) {
        seen->compat_expected = expected;
        seen->compat_pin = command.pin;
      }
    }
    progress.show("sending " + command.name + "...");
    nlohmann::ordered_json result = {{"message", command.name},
                                     {"acked", false},
                                     {"written", false},
                                     {"message_id", nullptr},
                                     {"attempts", 0},
                                     {"error", nullptr},
                                     {"device_errors", nlohmann::ordered_json::array()}};
    proxy::error_code send_error;
    if (command.reset && mode == proxy::Mode::primary) {
      // Reset is the session's own message: restart the session and wait for the new one.
      std::size_t sessions = 0;
      {
        const std::lock_guard lock(seen->mutex);
        sessions = seen->sessions;
      }
      client.restart_session();
      std::unique_lock lock(seen->mutex);
      const auto limit = proxy_options.open_timeout;
      if (seen->changed.wait_for(lock, limit, [&] { return seen->sessions > sessions || seen->link_error; }) &&
          !seen->link_error) {
        result["acked"] = true;
        result["written"] = true;
        result["session_id"] = seen->session_id;
      } else {
        result["error"] = seen->link_error ? "link failed: " + *seen->link_error
                                           : "no new session within " + std::to_string(limit.count()) + " ms";
        send_error = boost::system::errc::make_error_code(boost::system::errc::timed_out);
      }
    } else {
      proxy::SendResult sent;
      if (const auto* primary = std::get_if<proxy::ArduinoIn>(&command.message)) {
        sent = client.send(*primary, send_error);
      } else {
        sent = client.send(std::get<RocketryProto::ArduinoIn>(command.message), send_error);
        if (!send_error) {
          // Compat: the device answers every message with an EventMessage or an ErrorMessage.
          std::unique_lock lock(seen->mutex);
          seen->changed.wait_for(lock, std::chrono::milliseconds(arguments.settle_ms),
                                 [&] { return seen->compat_answers > 0 || seen->link_error; });
        }
      }
      result["acked"] = sent.acked;
      result["written"] = !send_error;
      if (mode == proxy::Mode::primary && sent.message_id != 0) result["message_id"] = sent.message_id;
      result["attempts"] = sent.attempts;
      if (send_error) result["error"] = send_error.message();
      // The device acked it as refused: its Error says why (exit 1, like any device error), not a failed send.
      if (send_error == proxy::ProxyError::refused) result["refused"] = true;
    }
    progress.clear();

    std::string line = command.name + ": ";
    {
      const std::lock_guard lock(seen->mutex);
      for (const std::string& text : seen->device_errors) result["device_errors"].push_back(text);
      for (const proxy::events::PinReport& report : seen->pin_reports) {
        if (command.pin && report.pin == *command.pin) {
          result["pin_state"] = {{"pin", report.pin}, {"value", report.value}, {"failsafe", report.failsafe}};
        }
      }
      if (mode == proxy::Mode::compat) {
        result["device_events"] = seen->compat_events;
        result["other_device_events"] = seen->other_events;
        result["device_answered"] = seen->compat_answers > 0;
      }
    }
    const bool refused = result.contains("refused");
    if (refused) {
      line += "refused, message id " + std::to_string(result["message_id"].get<std::uint32_t>()) + ", " +
              plural(result["attempts"].get<std::uint32_t>(), "attempt");
    } else if (send_error) {
      line += "failed: " + result["error"].get<std::string>();
    } else if (command.reset && mode == proxy::Mode::primary) {
      line += "new session " + std::to_string(result["session_id"].get<std::uint32_t>());
    } else if (mode == proxy::Mode::primary) {
      line += "acked, message id " + std::to_string(result["message_id"].get<std::uint32_t>()) + ", " +
              plural(result["attempts"].get<std::uint32_t>(), "attempt");
    } else {
      line += "written";
      for (const auto& event : result["device_events"]) line += "; device: " + event.get<std::string>();
      if (!result["device_answered"].get<bool>()) {
        line += "; no answer from the device within " + std::to_string(arguments.settle_ms) + " ms";
      }
    }
    if (result.contains("pin_state")) {
      line += "; pin " + std::to_string(result["pin_state"]["pin"].get<std::uint32_t>()) + " = " +
              std::to_string(result["pin_state"]["value"].get<std::int32_t>());
      if (result["pin_state"]["failsafe"].get<bool>()) line += " (failsafe)";
    }
    for (const auto& text : result["device_errors"]) line += "; device error: " + printable(text.get<std::string>());

    if (arguments.json) {
      out().line(dump(result));
    } else {
      out().line(line);
    }
    if (send_error && !refused) {
      std::fprintf(stderr, "tether send: %s: %s\n", command.name.c_str(), result["error"].get<std::string>().c_str());
      status = 2;
      break;
    }
    if (refused || !result["device_errors"].empty()) status = 1;
  }
  device->close();
  return status;
}

}  // namespace tether::cli

namespace tether::proxy {

/// The subcommands this codec adds to `tether` (collected by tools/tether/CMakeLists.txt:
/// plugin_subcommands.cpp.in).
std::vector<cli::Command> subcommands();

std::vector<cli::Command> subcommands() {
  return {{"send", cli::run_send,
           "send proxy messages by name and fields (servo-control pin=9 position=90); print the acks"}};
}

}  // namespace tether::proxy
