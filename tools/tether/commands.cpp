// The subcommand table: one row per subcommand (name, entry point, one-line help).
#include "commands.hpp"

namespace tether::cli {

namespace {

constexpr Command kCommands[] = {
    {"sim", run_sim, "run a firmware image on a virtual Arduino Uno, its UART on a pseudo-terminal"},
    {"call", run_call, "send one Romi command to a device (serial port or pty) and print its answer as JSON"},
    {"send", run_send, "send proxy messages by name and fields (servo-control pin=9 position=90); print the acks"},
    {"shell", run_shell, "interactive terminal for a device: type messages, see answers and what it sends"},
    {"monitor", run_monitor, "decode and print everything a device sends, with timestamps (passive)"},
    {"demo", run_demo, "compare the protocols: the same servo workload on every device of a (virtual) rover, with noise and resets"},
    {"bench", run_bench, "benchmark the protocols over noise and rates: latency, bytes, CPU, saturation; JSON, CSV, plots, report.html"},
    {"flash", run_flash, "upload a firmware image through the board's bootloader (avrdude, optiboot), verified"},
    {"stats", run_stats, "run a session with a device for a while and print its link and codec counters"},
};

}  // namespace

std::span<const Command> commands() { return kCommands; }

}  // namespace tether::cli
