// The rpc codec as the `tether` command shows it: requests typed as `FIELD=VALUE` words (or one JSON
// object), replies and stream messages as JSON objects in protobuf's JSON mapping, the client's events as
// shell lines, and the monitor's decoder of the envelope (methods and fields by name when it has the
// schema). All by protobuf reflection over the schema read at run time, so any schema needs no change
// here; the fuzz target (fuzz/rpc_text_fuzz.cpp) runs these very paths.
#pragma once

#include <google/protobuf/message.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/devices/config.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/schema.hpp"

namespace tether::cli {

/// Fills `request` from `words`: one word starting with `{` is the whole request as JSON (protobuf's
/// mapping: repeated and nested fields); else each word is `FIELD=VALUE` (the field's name as declared or
/// its JSON name), a scalar field at most once. Values: integers in the field's range, numbers,
/// true/false (1/0), strings as typed, bytes in base64 (as the JSON form and the replies: `AQID` is
/// 01 02 03), enums by name or number. Nothing on success, else what is
/// wrong, naming the field or value (`MoveJoint has no field "jiont" (fields: joint, angle_cdeg)`).
std::optional<std::string> fill_rpc_request(google::protobuf::Message& request, std::span<const std::string> words);

/// nanopb's bounds of a schema's string, bytes and repeated fields as its `.options` files say them: the
/// file beside each .proto of the schema (`sensor.options` beside `sensor.proto`; an import's beside it,
/// by the import's name), read as nanopb's generator reads it (`max_size`, `max_length`, `max_count` on a
/// field, on its message or on a wildcard pattern; later lines win). The device refuses a request over a
/// bound as one that does not decode, without naming the field; the host names it before sending. A
/// field no file bounds is not checked (bounds written in the .proto as `(nanopb)` options are not read).
class RpcBounds {
 public:
  /// The bounds of `schema`'s files; none when they have no .options file beside them.
  explicit RpcBounds(const rpc::Schema& schema);
  /// Nothing when every field of `message` (nested ones included) is within its bound; else the first
  /// field over one, e.g. `label: 7 bytes, over its .options bound (sensor.options: max_size:6, a string
  /// of at most 5 bytes)`.
  std::optional<std::string> check(const google::protobuf::Message& message) const;

 private:
  struct Line {
    std::string pattern;                         // nanopb's name pattern: `pkg.Message.field`, `*.label`
    std::map<std::string, std::uint64_t> values;  // max_size, max_length, max_count
  };
  struct File {
    std::string name;  // the .options file's name, for the messages
    std::vector<Line> lines;
  };
  std::optional<std::string> check(const google::protobuf::Message& message, const std::string& path) const;
  std::map<std::string, File> files_;  // by the .proto's name in the schema's pool
};

/// `message` as one JSON object on one line: protobuf's JSON names, every field (defaults included).
std::string rpc_message_json(const google::protobuf::Message& message);

/// `message` as a JSON value (what `rpc_message_json` prints), for the `--json` objects.
nlohmann::ordered_json rpc_message_value(const google::protobuf::Message& message);

/// `no method "X" in arm.proto (methods: MoveJoint, Watch)`.
std::string rpc_unknown_method(const rpc::Schema& schema, std::string_view name);

/// One line per method: `MoveJoint joint=uint32 angle_cdeg=int32`, `Watch (stream)`.
std::string rpc_method_list(const rpc::Schema& schema, std::string_view indent);

/// A client event as a shell line (`session 0x5e55 established`, `schema mismatch: ...`).
ShellLine rpc_event_line(const rpc::Event& event);

/// A device's error answer (`RpcError::device_error`, `refused`) as a shell line / the `--json` fields.
ShellLine rpc_device_error_line(std::string_view method, const rpc::error_code& error, const rpc::DeviceError& answer);

/// `tether monitor`'s decoder of rpc frames for the role's direction: the envelope, and with `schema` (not
/// null) each call's request, reply and stream message by method and field names. A reply or stream
/// message names its method when the schema leaves no doubt (one unary or one streaming method) or when
/// the host's side of the same monitor (`--tap`) saw the call; else its payload in hex.
std::unique_ptr<MonitorDecoder> make_rpc_monitor_decoder(std::shared_ptr<const rpc::Schema> schema,
                                                         const DecoderRole& role);

/// The schema of an rpc device's configuration (null when it names none or it does not read).
std::shared_ptr<const rpc::Schema> rpc_config_schema(const devices::DeviceConfig& config);

}  // namespace tether::cli
