// One line of `tether shell` output, as a text line and as JSON fields. Each codec's plugin makes them of
// what its devices say (codecs/<codec>/plugin/src/<codec>_text.hpp).
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace tether::cli {

/// One line of shell output in both forms.
struct ShellLine {
  std::string text;             ///< what a person reads
  nlohmann::ordered_json json;  ///< the JSON fields after "type"
};

/// The printed line: `line.text`, or with `json` the object `{"type": type, <line.json>}` on one line.
std::string shell_output(std::string_view type, const ShellLine& line, bool json);

}  // namespace tether::cli
