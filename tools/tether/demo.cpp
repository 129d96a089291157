// `tether demo [--config FILE] [options]`: the same servo workload through every device of a rover, with
// line noise and one reset per device halfway, printed side by side (tools/demo, rover_demo.hpp). With no
// arguments it starts the embedded virtual rover (simulated Unos: romi-rover, proxy, proxy-compat and two
// rings of elcano-node boards), so it needs no hardware.
//
// Output contract: stdout the table (or one JSON object with --json); progress on stderr when it is a
// terminal; exit status 0 when every device completed at least one operation after its reset (or, without
// resets, at least one operation), 1 when a device never did, 2 usage and setup errors (a bad config).
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "tether/demo/rover_demo.hpp"
#include "tether/devices/config.hpp"

namespace tether::cli {

namespace {

const CommandText& demo_command() {
  static const CommandText text(
      "demo",
      "usage: tether demo [--config FILE] [--iterations N] [--period MS] [--ber RATE] [--no-reset] [--seed N]\n"
      "                   [--json] [--record FILE [--force] [--record-max-bytes N|--record-max-seconds S]]\n"
      "\n"
      "Runs the same workload through every device of a rover and prints a side-by-side table per codec:\n"
      "operations, successes, wrong answers, wire bytes per operation, p50/p99 latency, retries, stale\n"
      "replies, CRC/framing drops, resets injected/detected, recovery time, and whether the servo pins show\n"
      "the last confirmed command. The workload: set the throttle (D9) and steering (D10) servos and get the\n"
      "device's confirmation, N times at a fixed period; noise on every host link from the start; each\n"
      "virtual device power-cycled once halfway.\n"
      "\n"
      "  --config FILE    a rover config (docs/config.md); default: the embedded virtual rover\n"
      "                   (docs/examples/rover-virtual.json: simulated Unos, no hardware needed)\n"
      "  --iterations N   operations per device (default 200)\n"
      "  --period MS      one operation every MS milliseconds per device (default 20: a 50 Hz loop)\n"
      "  --ber RATE       bit error rate injected on every host link, both directions (default 1e-4; 0: none)\n"
      "  --no-reset       do not power-cycle the virtual devices halfway (hardware is never reset)\n"
      "  --seed N         seed of the injected noise (default 1)\n"
      "  --json           print the report as one JSON object instead of the table\n"
      "  --record FILE    record every device's link into FILE (pcapng, one interface per device;\n"
      "                   docs/captures.md); an existing FILE is an error unless --force overwrites it;\n"
      "                   --record-max-bytes N or --record-max-seconds S start a ring file at N bytes or\n"
      "                   after S seconds (FILE, STEM.1.EXT, ...), --record-files N keeps N (default 2)\n"
      "\n"
      "Exit status: 0 every device completed operations (after its reset, when one was injected); 1 a device\n"
      "never did; 2 usage or configuration errors.\n");
  return text;
}

}  // namespace

int run_demo(int argc, char** argv) {
  demo::DemoOptions options;
  options.firmware_dir = firmware_dir();
  std::string config_file;
  DeviceOptions recording;  // --record, --force and the ring-file limits
  bool json = false;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    const std::string arg(argument);
    const auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (arg == "--json") {
      json = true;
    } else if (arg == "--no-reset") {
      options.reset_halfway = false;
    } else if (arg == "--config") {
      const char* file = value();
      if (file == nullptr) return demo_command().usage_error("--config needs a file");
      config_file = file;
    } else if (arg == "--iterations") {
      const char* text = value();
      const auto n = text ? parse_number(text, 1, 100000) : std::nullopt;
      if (!n) return demo_command().usage_error("--iterations needs a number 1..100000");
      options.iterations = *n;
    } else if (arg == "--period") {
      const char* text = value();
      const auto n = text ? parse_number(text, 0, 60000) : std::nullopt;
      if (!n) return demo_command().usage_error("--period needs milliseconds 0..60000");
      options.period = std::chrono::milliseconds(*n);
    } else if (arg == "--ber") {
      const char* text = value();
      char* end = nullptr;
      const double rate = text ? std::strtod(text, &end) : -1.0;
      if (text == nullptr || end == text || *end != '\0' || !(rate >= 0.0 && rate <= 0.01)) {
        return demo_command().usage_error("--ber needs a rate 0..0.01");
      }
      options.bit_error_rate = rate;
    } else if (arg == "--seed") {
      const char* text = value();
      const auto n = text ? parse_number(text, 0, 0xFFFFFFFFu) : std::nullopt;
      if (!n) return demo_command().usage_error("--seed needs a number");
      options.seed = *n;
    } else if (std::string error; parse_record_flag(argc, argv, i, recording, error)) {
      if (!error.empty()) return demo_command().usage_error(error);
    } else {
      return demo_command().usage_error("unknown argument " + arg);
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, demo_command(), own)) return *status;

  try {
    std::string record_error;
    const std::optional<transports::RecordOptions> record = record_options(recording, record_error);
    if (!record_error.empty()) return demo_command().usage_error(record_error);
    options.config = rover_to_run(config_file, options.firmware_dir, record.value_or(transports::RecordOptions{}));
  } catch (const devices::ConfigError& error) {
    return demo_command().fail(error.what());
  }

  Progress progress("demo");
  std::mutex progress_mutex;
  std::map<std::string, unsigned> done;
  options.progress = [&](const std::string& device, unsigned count, unsigned total) {
    std::lock_guard lock(progress_mutex);
    done[device] = count;
    std::string text;
    for (const auto& [name, n] : done) text += name + " " + std::to_string(n) + "/" + std::to_string(total) + "  ";
    progress.show(text);
  };
  if (stderr_is_terminal()) progress.show("opening the rover...");

  demo::DemoReport report;
  try {
    report = demo::run_demo(options);
  } catch (const std::exception& error) {  // devices::ConfigError included
    progress.clear();
    return demo_command().fail(error.what());
  }
  progress.clear();

  if (json) {
    std::printf("%s\n", demo::format_json(report).c_str());
  } else {
    std::fputs(demo::format_table(report).c_str(), stdout);
  }
  for (const demo::DeviceReport& device : report.devices) {
    const bool recovered = device.resets_injected == 0 || !device.confirmed || device.recovery_ms.has_value();
    if (device.successes == 0 || !recovered) return 1;
  }
  return 0;
}

}  // namespace tether::cli
