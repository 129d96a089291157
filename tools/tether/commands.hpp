// The subcommands of the `tether` program: one file each, listed in commands.cpp.
#pragma once

#include <span>
#include <string_view>

namespace tether::cli {

/// A subcommand. `run` gets argv with argv[0] = the subcommand name and returns the exit status:
/// 0 success, 1 the device answered with an application error, 2 usage, setup, protocol or transport error
/// (timeouts included; message on stderr).
struct Command {
  std::string_view name;
  int (*run)(int argc, char** argv);
  std::string_view summary;  ///< one line for `tether --help`
};

/// Every subcommand, in the order `tether --help` lists them.
std::span<const Command> commands();

// --- one declaration per subcommand (defined in <name>.cpp) ---
int run_sim(int argc, char** argv);
int run_call(int argc, char** argv);
int run_send(int argc, char** argv);
int run_shell(int argc, char** argv);
int run_monitor(int argc, char** argv);
int run_stats(int argc, char** argv);
int run_demo(int argc, char** argv);
int run_bench(int argc, char** argv);
int run_flash(int argc, char** argv);

}  // namespace tether::cli
