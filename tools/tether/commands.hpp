// The subcommands of the `tether` program: one file each, listed in commands.cpp, plus those the codec
// plugins add (`tether_codec_plugin(... SUBCOMMANDS ...)`: `send` is the proxy's; `call` is one command
// whose part for each codec's devices is that codec's plugin's: Romi's and rpc's).
#pragma once

#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "tether/devices/config.hpp"

namespace tether::cli {

/// A subcommand. `run` gets argv with argv[0] = the subcommand name and returns the exit status:
/// 0 success, 1 the device answered with an application error, 2 usage, setup, protocol or transport error
/// (timeouts included; message on stderr).
struct Command {
  std::string_view name;
  int (*run)(int argc, char** argv);
  std::string_view summary;  ///< one line for `tether --help`
  /// Set for a subcommand several codecs have (`call`): the codec whose devices this `run` serves. The
  /// command lists such rows as one subcommand of that name, which runs the row of the codec its device
  /// options name (`codec_of_arguments`), else the default codec's row (which refuses the device in its
  /// own words), else the first. Unset: a subcommand of its own.
  std::optional<devices::Codec> codec = std::nullopt;
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
int run_replay(int argc, char** argv);
int run_stats(int argc, char** argv);
int run_demo(int argc, char** argv);
int run_bench(int argc, char** argv);
int run_flash(int argc, char** argv);
int run_ports(int argc, char** argv);

}  // namespace tether::cli
