/// @file plugin.hpp
/// The rpc codec's plugin: what a rover configuration's `"codec": "rpc"` device is (its schema file and the
/// client's timing, parsed and checked here; the schema is read at parse time, so a broken one is a
/// `ConfigError` before anything opens), how it opens (`rpc::Client` on the schema) and when it is ready
/// (the device answered the Hello with the same schema hash). Registered with the devices library by
/// codecs/rpc/plugin/CMakeLists.txt (`tether_codec_plugin`); docs/codecs.md, keys in docs/config.md.
///
/// @code
///   {"name": "arm", "codec": "rpc", "transport": {...}, "options": {"schema": "arm.proto"}}
///   auto arm = rover.client<rpc::Client>("arm");
///   std::string reply = arm->call_json("MoveJoint", R"({"joint": 2})");
/// @endcode
#pragma once

#include <chrono>
#include <filesystem>
#include <vector>

#include "tether/devices/codecs.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/schema.hpp"

namespace tether::rpc {

/// The `rpc` codec's value in the devices table (`DeviceConfig::codec`, `RoverDevice::codec`).
inline constexpr devices::Codec kCodec{4};

/// Options of an `rpc` device (keys in docs/config.md).
struct DeviceOptions {
  /// The schema file. Parsed from a configuration file: relative to the file's folder
  /// (`ParseOptions::base_dir`). Built in code: as given (a relative path is the working directory's).
  std::filesystem::path schema;
  /// Where its imports are found and which service it serves (`"import_paths"`, `"service"`).
  SchemaOptions schema_options;
  /// The client's timing (`RpcTiming`; its `baud` follows a serial transport's baud unless the
  /// configuration sets it) and first message id.
  Options client;
  /// How long opening waits for the device's Hello with the same schema.
  std::chrono::milliseconds open_timeout{15000};
};

/// What an rpc image does at boot, for `"boot": "detect"` (transports/boot_detection.hpp): `begin` sends 0x00
/// and a COBS frame holding `ResetEvent{session}`; that frame (kept for the client) is the announcement.
transports::BootSignature boot_signature();

/// How `tether replay --as-device` plays a recorded rpc device (transports/capture_replay.hpp): requests
/// matched without their id, the ids in Ack, Reply, DeviceError and StreamMessage made the live message's
/// (CRC-16 and COBS redone), pings acked, a message the recording lacks refused (DeviceError
/// unknown_method, Ack refused).
std::unique_ptr<transports::CaptureReplayer> capture_replayer();

/// The codec's row of the devices table: `rpc`.
std::vector<devices::CodecRow> codec_rows();

/// Reads `options.schema` (with its import paths and service). Throws `devices::ConfigError` at
/// `options_path + ".schema"` whose text is protoc's (`arm.proto:7:3: "int33" is not defined.`).
Schema load_schema(const DeviceOptions& options, const std::string& options_path);

}  // namespace tether::rpc
