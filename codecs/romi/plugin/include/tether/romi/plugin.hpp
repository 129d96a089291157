/// @file plugin.hpp
/// The Romi codec's plugin: what a rover configuration's `"codec": "romi"` device is (its options, parsed
/// and checked here) and how it opens (`romi::Client` on the device's byte stream). Registered with the
/// devices library by codecs/romi/plugin/CMakeLists.txt (`tether_codec_plugin`); docs/codecs.md.
///
/// @code
///   const auto& options = device.options.get<romi::DeviceOptions>();   // a DeviceConfig of codec romi
///   std::shared_ptr<romi::Client> arm = rover.devices()[0].client.get<romi::Client>();
/// @endcode
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "tether/core/session/request_table.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/romi/client.hpp"
#include "tether/romi/session_policy.hpp"

namespace tether::romi {

/// The codec's value in the devices table (`DeviceConfig::codec`, `RoverDevice::codec`).
inline constexpr devices::Codec kCodec{0};

/// Options of a `romi` device (keys in docs/config.md).
struct DeviceOptions {
  /// Attempt window, call budget, sends per call, re-send on a silent attempt (`romi::Options`).
  session::CallTiming timing = default_call_timing();
  /// Id of the first request (`first_id`, 0..254). Unset: random when the device opens. A fixed first id
  /// would make the first request of a restarted service look, to a device that remembers the last id of
  /// the previous session, like that request sent again (answered from its cache, or -15 by the reference).
  std::optional<std::uint8_t> first_id;
};

/// What a Romi image does at boot, for `"boot": "detect"` (transports/boot_detection.hpp): nothing, like
/// the reference RomiSerial, so the host probes once the line has been quiet for 1.2 s (optiboot's 1 s and a
/// margin), then every 1.1 s: `#\r\n`, an
/// empty frame, which every Romi firmware (Tether's and the reference) answers with an envelope error
/// (`#_[-6]:007f`) without running a handler; any `#...\r\n` line after it is the answer. A probe that lands
/// in optiboot restarts its 1 s window (every byte it receives does), hence never a faster retry.
transports::BootSignature boot_signature();

/// How `tether replay --as-device` plays a recorded Romi device (transports/capture_replay.hpp): requests
/// matched on their payload, answers sent with the live request's id and their CRC-8 over it, -16 (unknown
/// opcode) to a request the recording does not have, envelope errors as the firmware answers them.
std::unique_ptr<transports::CaptureReplayer> capture_replayer();

/// The codec's row of the devices table: `romi`, its option keys, parser and checks, `romi::Client`.
std::vector<devices::CodecRow> codec_rows();

}  // namespace tether::romi
