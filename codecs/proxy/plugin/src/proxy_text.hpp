// The proxy codec as the `tether` command shows it: messages as people type and read them
// (`servo-control pin=9 position=90`: kebab-case names of the schema's messages and fields, found by protobuf
// reflection, so a new message in the schema needs no change here), the client's events as shell lines, and
// the monitor's decoder. Beside the codec's command rows, so the command itself knows no codec; the fuzz
// targets run these very paths.
#pragma once

#include <google/protobuf/message.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "monitor_decoding.hpp"
#include "rocketry.pb.h"
#include "shell_text.hpp"
#include "tether/devices/config.hpp"
#include "tether/proxy/client.hpp"
#include "tether_proxy.pb.h"

namespace tether::cli {

/// `servoControl` -> `servo-control`.
std::string kebab_case(std::string_view camel);

/// A proxy message to send: the mode's `ArduinoIn` with one `data` alternative set. `reset` is Reset
/// (which the client sends itself: `restart_session()`).
struct ProxyCommand {
  std::string name;  ///< kebab-case message name
  std::variant<proxy::ArduinoIn, RocketryProto::ArduinoIn> message;
  bool reset = false;
  /// The pin the message concerns, when it has a `pin` field.
  std::optional<std::uint32_t> pin;
};

/// Parses `NAME [FIELD=VALUE ...]` (`words[0]` is the name) into a message of `mode`'s schema. Field names
/// may be kebab-case, camelCase or snake_case; every field of the message must be given once. Values:
/// decimal integers in the field's range (servo positions and safe positions: degrees 0..180, in both
/// modes); booleans true/false, 1/0, on/off, high/low. On failure nothing,
/// and `error` names the unknown message, field or bad value.
std::optional<ProxyCommand> parse_proxy_command(proxy::Mode mode, std::span<const std::string> words,
                                                std::string& error);

/// One line per message `mode` can send: `servo-control pin=N position=N`.
std::string proxy_message_list(proxy::Mode mode, std::string_view indent);

/// `ack messageId: 5` / `pinState pin: 9 value: 120`: the set alternative of an `ArduinoOut` (either
/// schema) and its fields.
std::string describe_proxy_message(const google::protobuf::Message& message);
/// `{"type": "ack", "fields": {"messageId": 5}}` of an `ArduinoOut`.
nlohmann::ordered_json proxy_message_json(const google::protobuf::Message& message);

/// A proxy client's event (`servo 9 = 90`, `device error: ...`, `session 7 established`, ...).
ShellLine proxy_event_line(const proxy::Event& event);

/// `tether monitor`'s decoder of proxy frames: the mode's schema for the role's direction; in primary mode
/// with `role.keepalive`, a Ping every second as output.
std::unique_ptr<MonitorDecoder> make_proxy_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                           Millis now);

}  // namespace tether::cli
