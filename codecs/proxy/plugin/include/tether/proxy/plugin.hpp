/// @file plugin.hpp
/// The proxy codec's plugin: what a rover configuration's `"codec": "proxy"` and `"codec": "proxy-compat"`
/// devices are (their options and pin inits, parsed and checked here), how they open (`proxy::Client` in
/// primary or compat mode) and when they are ready (the session handshake and the inits). Registered with
/// the devices library by codecs/proxy/plugin/CMakeLists.txt (`tether_codec_plugin`); docs/codecs.md.
///
/// @code
///   const auto& options = device.options.get<proxy::DeviceOptions>();   // a DeviceConfig of codec proxy
///   for (const proxy::PinInit& init : options.inits) log(init.pin);
/// @endcode
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "tether/devices/codecs.hpp"
#include "tether/proxy/client.hpp"

namespace tether::proxy {

/// The `proxy` codec's value in the devices table (`DeviceConfig::codec`, `RoverDevice::codec`).
inline constexpr devices::Codec kCodec{1};
/// The `proxy-compat` codec's value: the same client in compat mode (`proxy::Options::compat()`).
inline constexpr devices::Codec kCompatCodec{2};

/// One pin init a proxy device replays after every reset (`proxy::Client` registers it; see client.hpp).
struct PinInit {
  /// Which kind of output.
  enum class Kind {
    servo,    ///< `ServoInit{pin, safePosition}`; `safe_value` in degrees 0..180.
    digital,  ///< `DigitalInit{pin, safeState}`; `safe_value` 0 or 1.
  };
  Kind kind = Kind::servo;      ///< Servo or digital output.
  std::uint32_t pin = 0;        ///< Arduino pin number.
  std::int32_t safe_value = 0;  ///< Safe position (servo) or state (digital).
};

/// Options of a `proxy` or `proxy-compat` device (keys in docs/config.md).
struct DeviceOptions {
  /// Mode (from the codec) and timing (`ProxyTiming`; its `baud` follows a serial transport's baud unless
  /// the configuration sets it).
  Options client;
  /// Inits sent, in order, when the device opens (and replayed by the client after every reset).
  std::vector<PinInit> inits;
  /// How long opening waits for the session handshake (primary mode) and the inits.
  std::chrono::milliseconds open_timeout{15000};
};

/// What the `proxy` image does at boot, for `"boot": "detect"` (transports/boot_detection.hpp): at the end of
/// its setup it sends 0x00 and a COBS frame holding `ResetEvent{sessionId}`; that frame (kept for the client,
/// whose handshake starts from it) is the announcement. The `proxy-compat` image, like the deployed firmware,
/// sends nothing at boot and has no request without an effect: its devices wait a fixed `boot_wait`.
transports::BootSignature boot_signature();

/// How `tether replay --as-device` plays a recorded device of `mode` (transports/capture_replay.hpp):
/// primary: requests matched without their messageId, Acks sent with the live message's id (CRC-16 and COBS
/// redone), pings acked, a message the recording lacks refused (Error, then Ack `refused`); compat: whole
/// messages matched, answers as recorded, nothing to a message the recording lacks.
std::unique_ptr<transports::CaptureReplayer> capture_replayer(Mode mode);

/// The codec's rows of the devices table: `proxy` (primary mode) and `proxy-compat` (the deployed variant,
/// 57600 baud), one parser and client.
std::vector<devices::CodecRow> codec_rows();

}  // namespace tether::proxy
