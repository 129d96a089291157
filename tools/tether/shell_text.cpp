// What `tether shell` prints for what a device said (see shell_text.hpp).
#include "shell_text.hpp"

#include "cli_support.hpp"

namespace tether::cli {

std::string shell_output(std::string_view type, const ShellLine& line, bool json) {
  if (!json) return line.text;
  nlohmann::ordered_json full = {{"type", std::string(type)}};
  for (const auto& [key, value] : line.json.items()) full[key] = value;
  return dump(full);
}

}  // namespace tether::cli
