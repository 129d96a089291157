// The subcommand table: one row per subcommand (name, entry point, one-line help), the codec plugins' among them.
#include "commands.hpp"

#include <iterator>
#include <vector>

namespace tether::cli {

namespace {

constexpr Command kFirst[] = {
    {"sim", run_sim, "run a firmware image on a virtual Arduino Uno, its UART on a pseudo-terminal"},
};

constexpr Command kRest[] = {
    {"shell", run_shell, "interactive terminal for a device: type messages, see answers and what it sends"},
    {"monitor", run_monitor, "decode and print everything a device sends, with timestamps (passive)"},
    {"demo", run_demo, "compare the protocols: the same servo workload on every device of a (virtual) rover, with noise and resets"},
    {"bench", run_bench, "benchmark the protocols over noise and rates: latency, bytes, CPU, saturation; JSON, CSV, plots, report.html"},
    {"flash", run_flash, "upload a firmware image through the board's bootloader (avrdude, optiboot), verified"},
    {"stats", run_stats, "run a session with a device for a while and print its link and codec counters"},
};

}  // namespace

std::span<const Command> commands() {
  static const std::vector<Command> table = [] {
    std::vector<Command> rows(std::begin(kFirst), std::end(kFirst));
    const std::vector<Command> plugins = detail::plugin_subcommands();
    rows.insert(rows.end(), plugins.begin(), plugins.end());
    rows.insert(rows.end(), std::begin(kRest), std::end(kRest));
    return rows;
  }();
  return table;
}

}  // namespace tether::cli
