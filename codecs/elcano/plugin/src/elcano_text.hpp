// The Elcano ring as the `tether` command shows it: messages as text (`D{s 50}{a 25}`) and JSON, sets of
// message types (`--capture drive,sensor`), the ring client's events as shell lines, and the monitor's
// decoders (the host's ring node, or a plain reader on a tap). Beside the codec's command rows, so the
// command itself knows no codec; the fuzz targets run these very paths.
#pragma once

#include <nlohmann/json.hpp>

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/devices/config.hpp"
#include "tether/elcano/client.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"

namespace tether::cli {

/// Parses a typed Elcano message (`D{s 50}{a 25}`, generation B syntax, or generation D with its CRC
/// trailer); a missing trailing newline is fine. Nothing on failure, with the reader's reason in `error`.
std::optional<elcano::Message> parse_elcano(std::string_view text, std::string& error);
/// The message as the writer puts it on the wire in `generation`, without the newline.
std::string format_elcano(const elcano::Message& message, elcano::Generation generation);
/// `{"type": "drive", "s": 50, "a": 25}` (set fields only).
nlohmann::ordered_json elcano_json(const elcano::Message& message);
/// A set of message types: `drive,sensor` (also the header letters `D,S`; `none` or empty: no type).
std::optional<elcano::TypeSet> parse_elcano_types(std::string_view text);

/// An Elcano ring client's event (`undeliverable D{s 50}{a 25} (...)`, `read error: bad_crc`, ...).
ShellLine ring_event_line(const elcano::Event& event, elcano::Generation generation);
/// `captured D{s 50}{a 25}`: a message the host's node captured.
ShellLine captured_line(const elcano::Message& message, elcano::Generation generation);

/// `tether monitor`'s decoder: the host's ring node (captures, forwards the rest, paced) when
/// `role.ring_node`, else a plain reader of the messages.
std::unique_ptr<MonitorDecoder> make_elcano_monitor_decoder(const devices::DeviceConfig& config,
                                                            const DecoderRole& role, Millis now);

}  // namespace tether::cli
