/// @file plugin.hpp
/// The Elcano codec's plugin: what a rover configuration's `"codec": "elcano"` device is (the host's node
/// in a ring: its options, parsed and checked here) and how it opens (`elcano::RingClient`). Its transport
/// is a serial port or TCP link whose TX reaches the first board and RX comes from the last, or a
/// `virtual_ring` of simulated boards (config.hpp), whose `elcano-node` boards' settings the row reads
/// (node_settings.hpp: also the node file of `tether flash --eeprom`). Registered with the devices library by
/// codecs/elcano/plugin/CMakeLists.txt (`tether_codec_plugin`); docs/codecs.md.
///
/// @code
///   const auto& options = device.options.get<elcano::DeviceOptions>();   // a DeviceConfig of codec elcano
/// @endcode
#pragma once

#include <vector>

#include "tether/core/session/request_table.hpp"
#include "tether/core/session/write_pacer.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/devices/json_reader.hpp"
#include "tether/elcano/client.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/session_policy.hpp"

namespace tether::elcano {

/// The codec's value in the devices table (`DeviceConfig::codec`, `RoverDevice::codec`).
inline constexpr devices::Codec kCodec{3};

/// Options of an `elcano` device, the host's node in the ring (keys in docs/config.md).
struct DeviceOptions {
  Generation generation = Generation::b;  ///< Wire generation of the ring.
  TypeSet capture;                        ///< Types the host consumes (besides call replies).
  /// The link to the next node: `receiver_buffer`, `receiver_poll_interval`; `baud` follows a serial
  /// transport (115200 otherwise).
  session::LinkPacing pacing;
  /// Calls (a request answered by a reply type): attempt window, budget, sends.
  session::CallTiming timing = default_call_timing();
};

/// A list of message type names (`["drive", "sensor"]`) as a set; a `ConfigError` for anything else or a
/// name listed twice. For `capture` here and in a ring board's settings.
TypeSet read_message_types(const devices::JsonNode& node);

/// How `tether replay --as-device` plays a recorded device of a ring of `generation`
/// (transports/capture_replay.hpp): messages matched as a node forwards them (without whitespace), answers
/// as recorded (no ids to rewrite), nothing to a message the recording lacks.
std::unique_ptr<transports::CaptureReplayer> capture_replayer(Generation generation);

/// The codec's row of the devices table: `elcano`, its option keys, parser and checks, carried by one
/// board or a virtual ring, `elcano::RingClient`.
std::vector<devices::CodecRow> codec_rows();

}  // namespace tether::elcano
