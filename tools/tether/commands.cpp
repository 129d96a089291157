// The subcommand table: one row per subcommand (name, entry point, one-line help).
#include "commands.hpp"

#include <cstdio>

namespace tether::cli {

namespace {

constexpr Command kCommands[] = {
    {"sim", run_sim, "run a firmware image on a virtual Arduino Uno, its UART on a pseudo-terminal"},
    {"call", run_call, "send one Romi command to a device (serial port or pty) and print its answer as JSON"},
};

}  // namespace

std::span<const Command> commands() { return kCommands; }

int usage_error(std::string_view command, const std::string& message, const char* usage) {
  std::fprintf(stderr, "tether %.*s: %s\n\n%s", static_cast<int>(command.size()), command.data(), message.c_str(),
               usage);
  return 2;
}

}  // namespace tether::cli
