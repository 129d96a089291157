// The subcommands of the `tether` program: one file each, listed in commands.cpp, plus those the codec
// plugins add (`tether_codec_plugin(... SUBCOMMANDS ...)`: `call` is the Romi plugin's, `send` the proxy's).
#pragma once

#include <span>
#include <string_view>
#include <vector>

namespace tether::cli {

/// A subcommand. `run` gets argv with argv[0] = the subcommand name and returns the exit status:
/// 0 success, 1 the device answered with an application error, 2 usage, setup, protocol or transport error
/// (timeouts included; message on stderr).
struct Command {
  std::string_view name;
  int (*run)(int argc, char** argv);
  std::string_view summary;  ///< one line for `tether --help`
};

/// Every subcommand, in the order `tether --help` lists them: `sim`, the codec plugins' (in plugin order), then
/// the rest.
std::span<const Command> commands();

namespace detail {
/// The subcommands of every codec plugin that has them (generated from plugin_subcommands.cpp.in).
std::vector<Command> plugin_subcommands();
}  // namespace detail

// --- one declaration per subcommand (defined in <name>.cpp) ---
int run_sim(int argc, char** argv);
int run_shell(int argc, char** argv);
int run_monitor(int argc, char** argv);
int run_stats(int argc, char** argv);
int run_demo(int argc, char** argv);
int run_bench(int argc, char** argv);
int run_flash(int argc, char** argv);

}  // namespace tether::cli
