// `tether stats DEVICE [--duration S] [--probe CMD | --passive] [--interval MS] [--json]`: opens a session
// with the device, keeps it alive for a while, and prints the session's counters.
//
// Output contract: a table on stdout (`key  value`, sections indented), or with --json one JSON object:
// {"device": ..., "codec": ..., "seconds": ..., "link": {LinkCounters}, "proxy"/"ring"/"calls": {...}}.
// A supervised serial port's outages are reported on stderr as they happen (`tether stats: link down: ...`,
// `link up after N ms (PATH)`) and counted in the report's "port" object.
// Exit status: 0 once the counters are printed (also after SIGINT/SIGTERM, with what was collected so far);
// 2 usage errors and a device that cannot be opened.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/serial_port_stream.hpp"

namespace tether::cli {

namespace {

// The codecs' lines of the usage, from their rows: what runs meanwhile, and what --probe takes.
struct CodecTexts {
  std::string activity;  // `  romi          the probe command ...`
  std::string probes;    // `romi: the command sent ...; rpc: ...`
  std::string probing;   // `romi, rpc`
};

CodecTexts codec_texts() {
  CodecTexts texts;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr) continue;
    if (!commands->stats_activity.empty()) {
      std::string name(row->name);
      name.resize(std::max<std::size_t>(name.size() + 1, 14), ' ');
      texts.activity += "  " + name + std::string(commands->stats_activity);
    }
    if (!commands->probe_usage.empty()) {
      texts.probes += (texts.probes.empty() ? "" : "; ") + std::string(row->name) + ": " +
                      std::string(commands->probe_usage);
      texts.probing += (texts.probing.empty() ? "" : ", ") + std::string(row->name);
    }
  }
  return texts;
}

const CommandText& stats_command() {
  static const CodecTexts texts = codec_texts();
  static const CommandText text(
      "stats",
      std::string(
          "usage: tether stats DEVICE [--duration S] [--probe CMD | --passive] [--interval MS] [--json]\n"
          "\n"
          "Opens a session with the device, runs it for --duration seconds doing what keeps it alive, and\n"
          "prints the session's counters: the link counters every codec keeps (frames_ok, crc_errors,\n"
          "framing_errors, oversize_frames, resyncs, stale, retries, timeouts, resets, ...) and the codec's own.\n"
          "What runs meanwhile:\n") +
          texts.activity +
          "The same report is `:stats` in `tether shell`.\n"
          "\n" +
      device_usage() +
      "\n"
      "  --duration S   how long to run (default 5; 0: open, probe once, print)\n"
      "  --probe CMD    " + texts.probes + "\n"
      "  --passive      " + texts.probing + ": send no probe\n"
      "  --interval MS  " + texts.probing + ": time between probes (default 1000)\n"
      "  --json         print one JSON object instead of the table\n"
      "\n"
      "SIGINT/SIGTERM stop early and print what was counted so far. Exit status: 0 counters printed;\n"
      "2 usage errors, a device that cannot be opened.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct StatsArguments {
  DeviceOptions device;
  std::uint32_t duration_ms = 5000;
  std::string probe;
  bool passive = false;
  bool probe_given = false;
  std::uint32_t interval_ms = 1000;
  bool json = false;
};

std::optional<int> parse_stats_arguments(int argc, char** argv, StatsArguments& arguments) {
  const CommandText& text = stats_command();
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--passive") {
      arguments.passive = true;
    } else if (argument == "--duration" || argument == "--probe" || argument == "--interval") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--duration") {
        const auto duration = parse_seconds(value, 30.0 * 24 * 3600);
        if (!duration) return text.usage_error("--duration needs seconds, got '" + std::string(value) + "'");
        arguments.duration_ms = *duration;
      } else if (argument == "--interval") {
        const auto interval = parse_number(value, 10, 3600000);
        if (!interval)
          return text.usage_error("--interval needs milliseconds (10..3600000), got '" + std::string(value) + "'");
        arguments.interval_ms = *interval;
      } else {
        arguments.probe = value;
        arguments.probe_given = true;
      }
    } else {
      return text.unexpected_argument(argument);
    }
    return std::nullopt;
  };
  if (const auto status = parse_device_arguments(argc, argv, text, arguments.device, own)) return status;
  if (arguments.passive && arguments.probe_given) return text.usage_error("--probe and --passive exclude each other");
  return std::nullopt;
}

}  // namespace

int run_stats(int argc, char** argv) {
  StatsArguments arguments;
  if (const auto status = parse_stats_arguments(argc, argv, arguments)) return *status;
  std::string error;
  const auto target = resolve_device(arguments.device, default_codec(), error);
  if (!target) return stats_command().usage_error(error);
  const CodecCommands& commands = *codec_commands(target->config.codec);
  const bool probes = static_cast<bool>(commands.send_probe);
  if (!probes && (arguments.probe_given || arguments.passive)) {
    std::string probing;  // the codecs that take a probe
    for (const devices::CodecRow* row : devices::codec_rows()) {
      const CodecCommands* other = codec_commands(row->codec);
      if (other != nullptr && other->send_probe) probing += (probing.empty() ? "" : " or ") + std::string(row->name);
    }
    return stats_command().usage_error("--probe and --passive apply to the " + probing + " codec only");
  }
  const std::string probe = arguments.probe_given ? arguments.probe : std::string(commands.default_probe);
  if (probes && !arguments.passive) {
    if (const auto reason = commands.check_probe(probe)) {
      return stats_command().usage_error("--probe '" + probe + "': " + *reason);
    }
  }

  // Caught from before the opening: a stop signal while the device opens ends the run (exit 0) as later.
  const std::atomic<bool>& stop = catch_stop_signals();
  transports::IoThread io;
  Progress progress("stats");
  ClientHooks hooks;
  hooks.stopped = [&stop] { return stop.load(); };
  auto device = open_device(*target, io.executor(), hooks, progress, error);
  if (!device && stop) return 0;
  if (!device) return stats_command().fail(target->label + ": " + error);
  if (stop) {
    device->close();
    return 0;
  }
  const StopAction close_on_stop([&device] { device->close(); });  // Ctrl-C ends a probe call at once
  // An outage as it happens (its counters are in the report's "port"), on a line of its own: on a terminal
  // the progress line is erased first and comes back at its next update.
  if (const auto& port = device->port(); port && port->options().reconnect.enabled) {
    port->add_link_handler([erase = stderr_is_terminal() ? "\r\033[K" : ""](const transports::LinkEvent& event) {
      if (event.kind == transports::LinkEvent::Kind::up) {
        std::fprintf(stderr, "%stether stats: link up after %lld ms (%s)\n", erase,
                     static_cast<long long>(event.down_for.count()), event.path.c_str());
      } else {
        std::fprintf(stderr, "%stether stats: link %s: %s\n", erase, transports::to_string(event.kind),
                     event.reason.c_str());
      }
    });
  }

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto end = start + std::chrono::milliseconds(arguments.duration_ms);
  std::uint32_t calls = 0;
  std::uint32_t answered = 0;
  std::uint32_t failed = 0;
  auto next_probe = start;
  for (bool first = true; !stop; first = false) {
    const auto now = Clock::now();
    if (!first && now >= end) break;
    if (probes && !arguments.passive && now >= next_probe) {
      ++calls;
      ++(commands.send_probe(device->client(), probe) ? answered : failed);
      next_probe += std::chrono::milliseconds(arguments.interval_ms);
      continue;
    }
    if (first && arguments.duration_ms == 0) break;
    const auto seconds_left = std::chrono::duration_cast<std::chrono::seconds>(end - now).count();
    progress.show("counting, " + std::to_string(seconds_left + 1) + " s left...");
    auto wake = std::min(end, now + std::chrono::milliseconds(100));
    if (probes && !arguments.passive) wake = std::min(wake, next_probe);
    std::this_thread::sleep_until(wake);
  }
  progress.clear();

  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  nlohmann::ordered_json extra = nlohmann::ordered_json::object();
  if (probes) {
    extra["calls"] = {{"probe", arguments.passive ? nlohmann::ordered_json() : nlohmann::ordered_json(probe)},
                      {"sent", calls},
                      {"answered", answered},
                      {"failed", failed}};
  }
  const nlohmann::ordered_json report = stats_report(*device, seconds, extra);
  device->close();
  if (arguments.json) {
    out().line(dump(report));
  } else {
    out().raw(counters_table(report));
  }
  return 0;
}

}  // namespace tether::cli
