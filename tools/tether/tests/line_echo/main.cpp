// A test build of the `tether` command that also speaks the test-only line-echo codec: the codec is
// registered, then the subcommand named by argv[1] runs as in the shipped program.
#include <cstdio>
#include <string_view>

#include "commands.hpp"
#include "line_echo.hpp"
#include "tether/devices/virtual_boards.hpp"

int main(int argc, char** argv) {
  tether::devices::enable_virtual_boards();  // as the shipped `tether` does
  tether::line_echo::register_line_echo();
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <command> [args...]\n", argv[0]);
    return 2;
  }
  for (const auto& command : tether::cli::commands()) {
    if (command.name == std::string_view(argv[1])) return command.run(argc - 1, argv + 1);
  }
  std::fprintf(stderr, "unknown command '%s'\n", argv[1]);
  return 2;
}
