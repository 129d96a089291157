// What `tether shell` prints for what a device said: romi answers and log lines, proxy events, Elcano ring
// events and captured messages, each as a text line and as JSON fields. Separate from the command so the
// fuzz target `shell_text` runs exactly these paths on values built from random bytes.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

#include "tether/elcano/client.hpp"
#include "tether/proxy/client.hpp"
#include "tether/romi/client.hpp"

namespace tether::cli {

/// One line of shell output in both forms.
struct ShellLine {
  std::string text;             ///< what a person reads
  nlohmann::ordered_json json;  ///< the JSON fields after "type"
};

/// `log: text` of a romi log line.
ShellLine romi_log_line(std::string_view text);
/// The answer array of a romi call (`[0,1,2]`, `[-16]  error -16: unknown opcode`) for the typed `command`.
ShellLine romi_answer_line(std::string_view command, const romi::RomiResponse& response);
/// A proxy client's event (`servo 9 = 90`, `device error: ...`, `session 7 established`, ...).
ShellLine proxy_event_line(const proxy::Event& event);
/// An Elcano ring client's event (`undeliverable D{s 50}{a 25} (...)`, `read error: bad_crc`, ...).
ShellLine ring_event_line(const elcano::Event& event, elcano::Generation generation);
/// `captured D{s 50}{a 25}`: a message the host's node captured.
ShellLine captured_line(const elcano::Message& message, elcano::Generation generation);

/// The printed line: `line.text`, or with `json` the object `{"type": type, <line.json>}` on one line.
std::string shell_output(std::string_view type, const ShellLine& line, bool json);

}  // namespace tether::cli
