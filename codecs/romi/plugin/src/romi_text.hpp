// What the `tether` command prints for the Romi codec: a call's answer and the device's log lines (shell,
// `call`), and the monitor's decoder of the envelope (requests and responses share it). Beside the codec's
// command rows, so the command itself knows no codec; the fuzz targets run these very paths.
#pragma once

#include <memory>
#include <string_view>

#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/devices/config.hpp"
#include "tether/romi/client.hpp"

namespace tether::cli {

/// `log: text` of a romi log line.
ShellLine romi_log_line(std::string_view text);
/// The answer array of a romi call (`[0,1,2]`, `[-16]  error -16: unknown opcode`) for the typed `command`.
ShellLine romi_answer_line(std::string_view command, const romi::RomiResponse& response);

/// `tether monitor`'s decoder of Romi frames (either direction: requests and responses share the envelope).
std::unique_ptr<MonitorDecoder> make_romi_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                          Millis now);

}  // namespace tether::cli
