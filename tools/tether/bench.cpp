// `tether bench [options]`: the demo's workload swept over line noise and request rates on every device of a
// rover, written as bench.json, bench.csv, plots and report.html (tools/bench, bench.hpp; the plots and the
// page are drawn by plot_report.py with matplotlib). `tether bench --compare A.json B.json` shows two runs
// side by side.
//
// Output contract: stdout a summary table (or bench.json's content with --json); progress on stderr when it
// is a terminal; exit status 0 the run and its outputs are complete, 1 a measured device completed no
// operation at some point, 2 usage and setup errors (bad config, unwritable --out, the plots could not be
// drawn: JSON and CSV are written first) and, for --compare, malformed input.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "tether/bench/bench.hpp"
#include "tether/devices/config.hpp"

extern char** environ;

namespace tether::cli {

namespace {

const CommandText& bench_command() {
  static const CommandText text(
      "bench",
      "usage: tether bench [--config FILE] [--devices A,B] [--sweep ber=R,...] [--sweep rate=HZ,...|max]\n"
      "                    [--iterations N | --duration S] [--seed N] [--isolated] [--reset] [--out DIR]\n"
      "                    [--record FILE [--force] [--record-max-bytes N|--record-max-seconds S]]\n"
      "                    [--workload servo|sensor] [--payload small|large] [--saturation] [--no-plots]\n"
      "                    [--json]\n"
      "   or: tether bench --compare A.json B.json [--json]\n"
      "\n"
      "Measures the protocols side by side: the demo's workload (set the throttle and steering servos and get\n"
      "the device's confirmation; on an Elcano ring, a request round the ring) on every device of a rover, at\n"
      "every point of a sweep over line noise (bit error rate) and request rate, all devices at once or one\n"
      "at a time. Per device and point: operations, success %, wrong answers, p50/p90/p99/max latency and\n"
      "its CDF, wire bytes per operation each way and link utilisation, retries, timeouts, drops by cause\n"
      "(stale, CRC, framing, oversize), resets detected and recovery time (--reset). On virtual boards\n"
      "also the exactly-once figures of the firmware's execution witness (commands confirmed, executed,\n"
      "executed twice, executed but failed, confirmed but not executed), the device CPU per operation\n"
      "(cycles the simulated Unos executed, sleep left out; and the same less their background while idle,\n"
      "measured for 0.3 s after opening) and the firmware's size and SHA-256. Per device and bit error\n"
      "rate: the highest rate sustained with >= 99 % success and the lowest swept rate where it breaks down\n"
"(`rate=max` runs the closed loop: its throughput is the saturation rate); with --saturation, found by\n"
      "a ramp instead.\n"
      "\n"
      "Outputs in --out DIR: bench.json (every figure, the parameters, seed, firmware hashes, the Tether\n"
      "version), bench.csv (one row per device and point), the plots latency_cdf.png, success_vs_ber.png,\n"
      "p99_vs_rate.png, bytes_per_op.png, cpu_per_op.png, and report.html (tables, plots, parameters and a\n"
      "verdict per criterion: lowest latency, fewest bytes, most robust under noise, lowest device CPU).\n"
      "The plots are drawn with matplotlib (Debian: python3-matplotlib) by share/tether/bench/plot_report.py.\n"
      "\n"
      "  --config FILE      a rover config (docs/config.md); default: the embedded virtual rover\n"
      "                     (docs/examples/rover-virtual.json: simulated Unos, no hardware needed)\n"
      "  --devices A,B      measure only these devices (by name in the config)\n"
      "  --sweep ber=LIST   bit error rates on every measured host link, both directions, each 0..0.01\n"
      "                     (default 0,1e-4)\n"
      "  --sweep rate=LIST  operations per second per device, each 0.1..10000, or max: the closed loop\n"
      "                     (default 50)\n"
      "  --iterations N     operations per device and point (default 100)\n"
      "  --duration S       seconds per device and point instead of a count (0.1..3600)\n"
      "  --seed N           seed of the injected noise (default 1)\n"
      "  --workload W       the operation measured (each point's `workload` in bench.json):\n"
      "                     servo (default) the demo's: set the servos and get the confirmation; an\n"
      "                       Elcano ring: a drive request answered by the drive node's sensor report\n"
      "                     sensor: read a value back: Romi A[channel] -> [0,value] (the romi-rover\n"
      "                       image's ADC); proxy: a control, done when the device's PinState (compat:\n"
      "                       its state stream) reports the new value; Elcano: a goal round the ring\n"
      "                       (goal -> segment -> drive nodes) answered by the drive node's sensor report\n"
      "  --payload P        the operation's size (each point's `payload` in bench.json):\n"
      "                     demo (default) the demo's operation (sensor: as small)\n"
      "                     small: Romi S[t,s] / A[ch]; proxy one DigitalControl; Elcano D{s}{a} (sensor:\n"
      "                       a goal with short values)\n"
      "                     large: Romi L[t,s,\"32-char label\"] (a 55-byte frame) / R -> all six ADC\n"
      "                       channels; proxy one ServoControl with a two-byte position; Elcano a segment\n"
      "                       X{n}{s}{b}{p} through the segment node (sensor: a goal with 7-digit\n"
      "                       positions and {r})\n"
      "                     A device that cannot do it (a proxy config without the pin) is skipped\n"
      "  --isolated         one device at a time (default: all at once, as on a rover)\n"
      "  --record FILE      record every device's link into FILE (pcapng, docs/captures.md); an existing FILE\n"
      "                     is an error unless --force overwrites it; long runs: --record-max-bytes N or\n"
      "                     --record-max-seconds S start a ring file at N bytes or after S seconds (FILE,\n"
      "                     STEM.1.EXT, ...), --record-files N keeps N of them (default 2)\n"
      "  --saturation       after the sweep, per device and BER: a ramp of open-loop rates 10, 20, 40 ... 640\n"
      "                     op/s (each step --iterations or --duration long) that stops at the first step\n"
      "                     not sustained (< 99 % success, or < 95 % of the rate achieved): the highest\n"
      "                     sustained rate, where it breaks down and why, every step in bench.json\n"
      "  --reset            power-cycle each virtual device halfway through every point\n"
      "  --out DIR          where the outputs go (created; default ./tether-bench)\n"
      "  --no-plots         write bench.json and bench.csv only\n"
      "  --json             print bench.json's content instead of the summary table\n"
      "  --compare A B      print two runs' bench.json side by side (points in both, by device, BER and\n"
      "                     rate); differences beyond run-to-run noise are marked * (success %: beyond\n"
      "                     three binomial standard errors; latency: > 25 % and > 1 ms; bytes and CPU per\n"
      "                     operation: > 5 %)\n"
      "\n"
      "Exit status: 0 done; 1 a measured device succeeded in no operation at some point (--compare: differences\n"
      "were flagged); 2 usage or configuration errors, an unwritable --out, plots that could not be drawn\n"
      "(bench.json and bench.csv are written first), unreadable or malformed --compare files.\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

std::vector<std::string> split(std::string_view text, char separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = text.find(separator, start);
    parts.emplace_back(text.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return parts;
}

std::optional<double> parse_double(const std::string& text, double minimum, double maximum) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (errno != 0 || end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  if (value < minimum || value > maximum) return std::nullopt;
  return value;
}

// `KEY=V1,V2,...` into the options; the usage error's message otherwise.
std::optional<std::string> parse_sweep(std::string_view text, bench::BenchOptions& options) {
  const std::size_t equals = text.find('=');
  if (equals == std::string_view::npos) return "--sweep needs KEY=VALUES (ber=0,1e-4 or rate=10,50,max), got '" + std::string(text) + "'";
  const std::string key(text.substr(0, equals));
  const std::vector<std::string> values = split(text.substr(equals + 1), ',');
  if (key == "ber") {
    options.bit_error_rates.clear();
    for (const std::string& value : values) {
      const auto rate = parse_double(value, 0.0, 0.01);
      if (!rate) return "--sweep ber: '" + value + "' is not a bit error rate 0..0.01";
      options.bit_error_rates.push_back(*rate);
    }
  } else if (key == "rate") {
    options.rates.clear();
    for (const std::string& value : values) {
      if (value == "max") {
        options.rates.push_back(std::nullopt);
        continue;
      }
      const auto rate = parse_double(value, 0.1, 10000.0);
      if (!rate) return "--sweep rate: '" + value + "' is not a rate 0.1..10000 (operations per second) or max";
      options.rates.push_back(*rate);
    }
  } else {
    return "--sweep: unknown key '" + key + "' (known: ber, rate)";
  }
  return std::nullopt;
}

// Where plot_report.py is: $TETHER_BENCH_PLOT_SCRIPT, installed beside the firmware
// (bin/../share/tether/bench), else the source tree's.
std::filesystem::path plot_script() {
  if (const char* script = std::getenv("TETHER_BENCH_PLOT_SCRIPT"); script != nullptr && *script != '\0') return script;
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto installed = (self.parent_path() / TETHER_INSTALLED_BENCH_SCRIPT).lexically_normal();
    if (std::filesystem::exists(installed, error)) return installed;
  }
  return TETHER_SOURCE_BENCH_SCRIPT;
}

// What a stop signal (SIGINT, SIGTERM) during `run_program` returns.
constexpr int kProgramStopped = -2;

// Runs `program args...` (no shell, its own process group) and waits; its exit status, -1 when it could not
// start, kProgramStopped when a stop signal came first: the program (and what it started) is ended then, so
// no plot is written after bench has gone.
int run_program(const std::vector<std::string>& arguments) {
  std::vector<char*> argv;
  for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  const std::atomic<bool>& stop = catch_stop_signals();
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], nullptr, &attributes, argv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  if (spawned != 0) return -1;
  int status = 0;
  for (;;) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) return -1;
    if (stop) {
      end_process_group(pid, std::chrono::seconds(1));
      return kProgramStopped;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool write_file(const std::filesystem::path& path, const std::string& content) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << content;
  file.close();
  return static_cast<bool>(file);
}

std::optional<nlohmann::json> read_json(const std::string& path, std::string& error) {
  std::ifstream file(path);
  if (!file || std::filesystem::is_directory(path)) {
    error = path + ": " + std::strerror(std::filesystem::is_directory(path) ? EISDIR : errno);
    return std::nullopt;
  }
  try {
    return nlohmann::json::parse(file);
  } catch (const nlohmann::json::exception& parse_error) {
    error = path + ": invalid JSON: " + parse_error.what();
    return std::nullopt;
  }
}

int run_compare(const std::string& a, const std::string& b, bool json) {
  std::string error;
  const auto first = read_json(a, error);
  if (!first) return bench_command().fail(error);
  const auto second = read_json(b, error);
  if (!second) return bench_command().fail(error);
  bench::Comparison comparison;
  try {
    comparison = bench::compare(*first, *second);
  } catch (const std::invalid_argument& bad) {
    std::string message = bad.what();
    // The library names the documents A and B; the user knows them by their files.
    if (message.rfind("A", 0) == 0 && (message.size() == 1 || message[1] == '.' || message[1] == ':')) {
      message = a + message.substr(1);
    } else if (message.rfind("B", 0) == 0 && (message.size() == 1 || message[1] == '.' || message[1] == ':')) {
      message = b + message.substr(1);
    }
    return bench_command().fail(message);
  }
  if (json) {
    std::printf("%s\n", dump(nlohmann::ordered_json{{"a", a}, {"b", b}, {"flagged", comparison.flagged},
                                                    {"points", comparison.json}})
                            .c_str());
  } else {
    std::printf("A: %s\nB: %s\n\n%s", a.c_str(), b.c_str(), comparison.text.c_str());
  }
  return comparison.flagged == 0 ? 0 : 1;
}

std::string eta_text(double seconds) {
  const auto whole = static_cast<long>(std::lround(seconds));
  return whole >= 60 ? std::to_string(whole / 60) + " min " + std::to_string(whole % 60) + " s"
                     : std::to_string(whole) + " s";
}

}  // namespace

int run_bench(int argc, char** argv) {
  bench::BenchOptions options;
  options.firmware_dir = firmware_dir();
  options.tether_version = TETHER_VERSION;
  std::string config_file;
  DeviceOptions recording;  // --record, --force and the ring-file limits
  std::filesystem::path out_dir = "tether-bench";
  bool json = false;
  bool plots = true;
  bool iterations_given = false;
  std::vector<std::string> compare_files;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    const std::string arg(argument);
    const auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (arg == "--json") {
      json = true;
    } else if (arg == "--isolated") {
      options.isolated = true;
    } else if (arg == "--workload") {
      const char* kind = value();
      const std::string text = kind == nullptr ? "" : kind;
      if (text == "servo") {
        options.workload = bench::WorkloadKind::servo;
      } else if (text == "sensor") {
        options.workload = bench::WorkloadKind::sensor;
      } else {
        return bench_command().usage_error("--workload needs servo or sensor, got '" + text + "'");
      }
    } else if (arg == "--payload") {
      const char* size = value();
      const std::string text = size == nullptr ? "" : size;
      if (text == "small") {
        options.payload = bench::Payload::small;
      } else if (text == "large") {
        options.payload = bench::Payload::large;
      } else if (text == "demo") {
        options.payload = bench::Payload::demo;
      } else {
        return bench_command().usage_error("--payload needs small, large or demo, got '" + text + "'");
      }
    } else if (arg == "--saturation") {
      options.saturation_ramp = true;
    } else if (arg == "--reset") {
      options.reset = true;
    } else if (arg == "--no-plots") {
      plots = false;
    } else if (arg == "--config") {
      const char* file = value();
      if (file == nullptr) return bench_command().usage_error("--config needs a file");
      config_file = file;
    } else if (arg == "--devices") {
      const char* list = value();
      if (list == nullptr || *list == '\0') return bench_command().usage_error("--devices needs names: A,B");
      options.devices = split(list, ',');
      for (const std::string& name : options.devices) {
        if (name.empty()) return bench_command().usage_error("--devices: an empty name in '" + std::string(list) + "'");
      }
    } else if (arg == "--sweep") {
      const char* text = value();
      if (text == nullptr) return bench_command().usage_error("--sweep needs KEY=VALUES (ber=0,1e-4 or rate=10,50,max)");
      if (const auto error = parse_sweep(text, options)) return bench_command().usage_error(*error);
    } else if (arg == "--iterations") {
      const char* text = value();
      const auto n = text ? parse_number(text, 1, 100000) : std::nullopt;
      if (!n) return bench_command().usage_error("--iterations needs a number 1..100000");
      options.iterations = *n;
      iterations_given = true;
    } else if (arg == "--duration") {
      const char* text = value();
      const auto seconds = text ? parse_double(text, 0.1, 3600.0) : std::nullopt;
      if (!seconds) return bench_command().usage_error("--duration needs seconds 0.1..3600");
      options.duration = std::chrono::milliseconds(std::lround(*seconds * 1000.0));
    } else if (arg == "--seed") {
      const char* text = value();
      const auto n = text ? parse_number(text, 0, 0xFFFFFFFFu) : std::nullopt;
      if (!n) return bench_command().usage_error("--seed needs a number");
      options.seed = *n;
    } else if (arg == "--out") {
      const char* dir = value();
      if (dir == nullptr || *dir == '\0') return bench_command().usage_error("--out needs a folder");
      out_dir = dir;
    } else if (arg == "--compare") {
      const char* a = value();
      const char* b = value();
      if (a == nullptr || b == nullptr) return bench_command().usage_error("--compare needs two files: A.json B.json");
      compare_files = {a, b};
    } else if (std::string error; parse_record_flag(argc, argv, i, recording, error)) {
      if (!error.empty()) return bench_command().usage_error(error);
    } else {
      return bench_command().unexpected_argument(arg);
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, bench_command(), own)) return *status;
  if (!compare_files.empty()) return run_compare(compare_files[0], compare_files[1], json);
  if (iterations_given && options.duration) {
    return bench_command().usage_error("--iterations and --duration exclude each other");
  }

  // Usage errors before anything is written.
  std::string record_error;
  const std::optional<transports::RecordOptions> record = record_options(recording, record_error);
  if (!record_error.empty()) return bench_command().usage_error(record_error);

  // The output folder first: a run of minutes must not end in "cannot write".
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (error) return bench_command().fail("--out " + out_dir.string() + ": " + error.message());
  if (!write_file(out_dir / "bench.json", "{}\n")) {
    return bench_command().fail("--out " + out_dir.string() + ": cannot write bench.json there");
  }

  try {
    options.config = rover_to_run(config_file, options.firmware_dir, record.value_or(transports::RecordOptions{}));
  } catch (const devices::ConfigError& config_error) {
    return bench_command().fail(config_error.what());
  }

  Progress progress("bench");
  std::mutex progress_mutex;
  const auto started = std::chrono::steady_clock::now();
  options.progress = [&](std::size_t done, std::size_t total) {
    std::lock_guard lock(progress_mutex);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const double eta = done == 0 ? 0.0 : elapsed / static_cast<double>(done) * static_cast<double>(total - done);
    const std::size_t width = 30;
    const std::size_t filled = total == 0 ? width : width * done / total;
    progress.show("[" + std::string(filled, '#') + std::string(width - filled, '.') + "] " + std::to_string(done) +
                  "/" + std::to_string(total) + " device-points, ETA " + eta_text(eta));
  };
  if (stderr_is_terminal()) progress.show("opening the rover...");

  bench::BenchReport report;
  try {
    report = bench::run_bench(options);
  } catch (const std::exception& run_error) {  // devices::ConfigError included
    progress.clear();
    return bench_command().fail(run_error.what());
  }
  progress.clear();

  const nlohmann::json document = bench::to_json(report);
  const std::string json_text = document.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (!write_file(out_dir / "bench.json", json_text) || !write_file(out_dir / "bench.csv", bench::to_csv(report))) {
    return bench_command().fail("--out " + out_dir.string() + ": cannot write bench.json / bench.csv");
  }
  if (json) {
    std::fputs(json_text.c_str(), stdout);
  } else {
    std::fputs(bench::format_table(report).c_str(), stdout);
  }
  cli::out().flush();

  if (plots) {
    const std::string python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
    const std::filesystem::path script = plot_script();
    const int status = run_program({python, script.string(), (out_dir / "bench.json").string(), out_dir.string()});
    if (status == kProgramStopped) {
      return bench_command().fail("stopped while drawing the plots (the plotting was ended); bench.json and bench.csv "
                                 "are in " + out_dir.string());
    }
    if (status == 3) {
      return bench_command().fail("the plots need matplotlib (Debian: apt install python3-matplotlib); bench.json and "
                                 "bench.csv are in " + out_dir.string());
    }
    if (status != 0) {
      return bench_command().fail("drawing the plots failed (" + python + " " + script.string() + ", status " +
                                 std::to_string(status) + "); bench.json and bench.csv are in " + out_dir.string());
    }
    if (!json) std::printf("\nreport: %s\n", (out_dir / "report.html").string().c_str());
  }
  for (const bench::PointResult& point : report.points) {
    if (point.successes == 0) return 1;
  }
  return 0;
}

}  // namespace tether::cli
