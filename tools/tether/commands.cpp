// The subcommand table: one row per subcommand (name, entry point, one-line help), the codec plugins' among them.
#include "commands.hpp"

#include <iterator>
#include <string>
#include <vector>

#include "codec_commands.hpp"
#include "device_options.hpp"

namespace tether::cli {

namespace {

constexpr Command kFirst[] = {
    {"sim", run_sim, "run a firmware image on a virtual Arduino Uno, its UART on a pseudo-terminal"},
};

constexpr Command kRest[] = {
    {"shell", run_shell, "interactive terminal for a device: type messages, see answers and what it sends"},
    {"monitor", run_monitor, "decode and print everything a device sends, with timestamps (passive)"},
    {"replay", run_replay, "print a capture (--record, monitor --write) as monitor --tap would; check a firmware against it, play its device on a pty"},
    {"demo", run_demo, "compare the protocols: the same servo workload on every device of a (virtual) rover, with noise and resets"},
    {"bench", run_bench, "benchmark the protocols over noise and rates: latency, bytes, CPU, saturation; JSON, CSV, plots, report.html"},
    {"flash", run_flash, "upload a firmware image through the board's bootloader (avrdude, optiboot), verified"},
    {"stats", run_stats, "run a session with a device for a while and print its link and codec counters"},
    {"ports", run_ports, "list the serial ports (path, by-id, VID:PID, serial, product) and which configured device each is"},
};

// The plugins' subcommands, each codec's part of a shared one (`call`) among them.
const std::vector<Command>& plugin_rows() {
  static const std::vector<Command> rows = detail::plugin_subcommands();
  return rows;
}

// A subcommand several codecs have (argv[0] its name): the part of the codec of the device it names.
int run_codec_subcommand(int argc, char** argv) {
  const std::string_view name = argv[0];
  const devices::Codec codec = codec_of_arguments(argc, argv, default_codec());
  const Command* fallback = nullptr;
  for (const Command& row : plugin_rows()) {
    if (row.name != name || !row.codec) continue;
    if (*row.codec == codec) return row.run(argc, argv);
    if (fallback == nullptr || *row.codec == default_codec()) fallback = &row;
  }
  return fallback->run(argc, argv);  // the table lists the name only when a row has it
}

// One row per shared subcommand, where its first codec's part is; its summary is the parts' joined.
std::vector<Command> merge_codec_parts(const std::vector<Command>& plugins) {
  static std::vector<std::string> summaries;  // the joined summaries (built once: the table is)
  std::vector<Command> rows;
  for (const Command& row : plugins) {
    std::size_t found = rows.size();
    for (std::size_t i = 0; row.codec && i < rows.size(); ++i) {
      if (rows[i].name == row.name && rows[i].run == run_codec_subcommand) found = i;
    }
    if (found < rows.size()) {
      summaries[found] += "; " + std::string(row.summary);
      continue;
    }
    rows.push_back(row.codec ? Command{row.name, run_codec_subcommand, {}, std::nullopt} : row);
    summaries.emplace_back(row.summary);
  }
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].run == run_codec_subcommand) rows[i].summary = summaries[i];
  }
  return rows;
}

}  // namespace

std::span<const Command> commands() {
  static const std::vector<Command> table = [] {
    std::vector<Command> rows(std::begin(kFirst), std::end(kFirst));
    const std::vector<Command> plugins = merge_codec_parts(plugin_rows());
    rows.insert(rows.end(), plugins.begin(), plugins.end());
    rows.insert(rows.end(), std::begin(kRest), std::end(kRest));
    return rows;
  }();
  return table;
}

}  // namespace tether::cli
