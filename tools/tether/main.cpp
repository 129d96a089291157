// `tether <subcommand> [args]`: dispatches to the subcommands listed in commands.cpp.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "cli_support.hpp"
#include "commands.hpp"
#include "tether/devices/virtual_boards.hpp"

#ifndef TETHER_VERSION
#error "TETHER_VERSION must be the project's version (top-level CMakeLists.txt)"
#endif

namespace {

void print_usage(std::FILE* out) {
  // "Usage:" and "or:" as GNU programs write them: help2man makes the man page's SYNOPSIS of these lines.
  std::fprintf(out,
               "Usage: tether <command> [args...]\n"
               "  or:  tether <command> --help\n"
               "  or:  tether --version\n\n"
               "commands:\n");
  std::size_t width = 0;
  for (const auto& command : tether::cli::commands()) width = std::max(width, command.name.size());
  for (const auto& command : tether::cli::commands()) {
    std::fprintf(out, "  %-*.*s  %.*s\n", static_cast<int>(width), static_cast<int>(command.name.size()),
                 command.name.data(), static_cast<int>(command.summary.size()), command.summary.data());
  }
}

// A result that did not reach its reader (a full disk, a closed stdout, a reader that stopped reading) is
// a failure, whatever the command concluded: exit 2 and say why on stderr. Writers go through stdout's
// stream (std::cout is synced with it), whose error flag has seen every failed write, or through the line
// printer, which remembers its own.
int checked_output(std::string_view command, int status) {
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  const int flush_errno = errno;
  std::string reason = tether::cli::out().write_failure();
  if (reason.empty() && flushed && std::ferror(stdout) == 0) return status;
  if (reason.empty() && flush_errno != 0) reason = std::strerror(flush_errno);
  std::fprintf(stderr, "tether %.*s: the output could not be written%s%s\n", static_cast<int>(command.size()),
               command.data(), reason.empty() ? "" : ": ", reason.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  tether::devices::enable_virtual_boards();  // --virtual, `sim`, `demo` and configurations with virtual devices
  if (argc < 2) {
    print_usage(stderr);
    return 2;
  }
  const std::string_view name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    if (name == "help" && argc > 2) {
      for (const auto& command : tether::cli::commands()) {
        if (command.name == argv[2]) {
          char help[] = "--help";
          char* forwarded[] = {argv[2], help, nullptr};
          return checked_output(command.name, command.run(2, forwarded));
        }
      }
    }
    print_usage(stdout);
    return checked_output("--help", 0);
  }
  if (name == "--version") {
    std::printf("tether %s\n", TETHER_VERSION);
    return checked_output("--version", 0);
  }
  for (const auto& command : tether::cli::commands()) {
    if (command.name == name) return checked_output(name, command.run(argc - 1, argv + 1));
  }
  std::fprintf(stderr, "tether: unknown command '%s'\n\n", argv[1]);
  print_usage(stderr);
  return 2;
}
