// `tether <subcommand> [args]`: dispatches to the subcommands listed in commands.cpp.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "commands.hpp"

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

}  // namespace

int main(int argc, char** argv) {
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
          return command.run(2, forwarded);
        }
      }
    }
    print_usage(stdout);
    return 0;
  }
  if (name == "--version") {
    std::printf("tether %s\n", TETHER_VERSION);
    return 0;
  }
  for (const auto& command : tether::cli::commands()) {
    if (command.name == name) return command.run(argc - 1, argv + 1);
  }
  std::fprintf(stderr, "tether: unknown command '%s'\n\n", argv[1]);
  print_usage(stderr);
  return 2;
}
