// Messages as people type and read them: proxy messages as `servo-control pin=9 position=90` (kebab-case
// names of the schema's messages and fields, found by protobuf reflection, so a new message in the schema
// needs no change here), and Elcano messages as `D{s 50}{a 25}`.
#pragma once

#include <google/protobuf/message.h>

#include <nlohmann/json.hpp>

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "rocketry.pb.h"
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/proxy/client.hpp"
#include "tether_proxy.pb.h"

namespace tether::cli {

/// Text a device sent, safe to print on a terminal: C0 control bytes (NUL, ESC, BEL, CR, LF, ...), DEL,
/// C1 controls (U+0080..U+009F) and bytes that are not UTF-8 become `\xNN` (one per byte); valid UTF-8
/// otherwise passes unchanged. Every human-readable line that carries device text goes through it (JSON
/// output escapes on its own).
std::string printable(std::string_view bytes);

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

/// Parses a typed Elcano message (`D{s 50}{a 25}`, generation B syntax, or generation D with its CRC
/// trailer); a missing trailing newline is fine. Nothing on failure, with the reader's reason in `error`.
std::optional<elcano::Message> parse_elcano(std::string_view text, std::string& error);
/// The message as the writer puts it on the wire in `generation`, without the newline.
std::string format_elcano(const elcano::Message& message, elcano::Generation generation);
/// `{"type": "drive", "s": 50, "a": 25}` (set fields only).
nlohmann::ordered_json elcano_json(const elcano::Message& message);
/// A set of message types: `drive,sensor` (also the header letters `D,S`; `none` or empty: no type).
std::optional<elcano::TypeSet> parse_elcano_types(std::string_view text);

}  // namespace tether::cli
