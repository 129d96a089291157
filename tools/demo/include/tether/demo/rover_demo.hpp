/// @file rover_demo.hpp
/// `tether demo`: the same workload through every device of a rover, one device per codec, with line
/// noise and one reset per device halfway, measured side by side.
///
/// The workload is what a rover service does most: command the throttle (D9) and steering (D10) servos
/// and get the device's confirmation, `iterations` times with changing values. On the wire:
///   - romi: one call `S[throttle_us,steering_us]` answered `[0]` (romi-rover image);
///   - proxy: two `ServoControl` messages (D9, D10) sent together, each acknowledged;
///   - proxy-compat: ServoControl for the servos its config inits; the deployed variant has no acks, so an
///     operation "succeeds" when written (its latency is the write time, not a round trip, and what the
///     device lost while rebooting is only visible on the pins). After the run (noise off) the demo writes
///     the last positions again until the device's 50 ms state stream reports them (`final_rewrites`),
///     which the deployed host never does: only then is the pins' final state a known command. Expected
///     pulses follow the deployed Servo library's 544..2400 us;
///   - elcano: one request `D{s speed}{a angle}` into the ring, answered by the `S` report of the node
///     that drives the servos (the reply's speed and angle must match: a mismatch is a wrong answer).
/// Each device runs on its own thread, so the devices run at the same time and the total is the slowest.
///
/// Faults (virtual devices; noise also on hardware): every host link is wrapped in a
/// `transports::FaultInjectingStream` (which also counts the wire bytes) with `bit_error_rate` from the
/// first operation on; at `iterations / 2` the device's board (a ring's last board, the one driving the
/// servos) is power-cycled. Afterwards the servo pulses measured on the virtual pins are compared with the
/// last operation that succeeded.
///
/// Every figure in a report is measured in the run: nothing is estimated or fixed in advance.
#pragma once

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tether/demo/exactly_once.hpp"
#include "tether/devices/config.hpp"

namespace tether::demo {

/// What to run.
struct DemoOptions {
  /// The rover; default (unset): the embedded virtual rover (devices::default_virtual_rover_config()).
  std::optional<devices::RoverConfig> config;
  /// Firmware folder for the embedded config's image names.
  std::filesystem::path firmware_dir;
  /// Operations per device.
  unsigned iterations = 200;
  /// Run for this long instead of `iterations` operations (0: use `iterations`). A soak (tools/soak).
  std::chrono::milliseconds duration{0};
  /// Power-cycle each virtual device every `reset_every` operations (0: once, halfway, per `reset_halfway`).
  unsigned reset_every = 0;
  /// One operation starts every `period` (a 50 Hz control loop), or at once when the previous one took
  /// longer: every codec sees the same timeline, and the reset lands at the same moment for all.
  std::chrono::milliseconds period{20};
  /// Bit error rate on every host link (both directions); 0: no noise.
  double bit_error_rate = 1e-4;
  /// Power-cycle each virtual device once, halfway.
  bool reset_halfway = true;
  /// How long a board stays powered off in the reset.
  std::chrono::milliseconds power_off{100};
  /// Seed of the noise.
  std::uint64_t seed = 1;
  /// Progress: called from the device threads with (device, operations done, iterations; 0 with a
  /// `duration`). May be empty.
  std::function<void(const std::string& device, unsigned done, unsigned total)> progress;
};

/// Distinct failure causes a DeviceReport keeps apart.
inline constexpr std::size_t kMaxFailureCauses = 16;

/// What one device did.
struct DeviceReport {
  std::string device;       ///< Name in the config.
  std::string codec;        ///< `romi`, `proxy`, `proxy-compat`, `elcano`.
  std::string transport;    ///< One-line description.
  std::string operation;    ///< What one operation is on the wire.
  bool confirmed = true;         ///< The device confirms operations (false: proxy-compat, written only).
  std::uint32_t operations = 0;  ///< Operations attempted.
  std::uint32_t successes = 0;   ///< Confirmed (compat: written) with the right values.
  std::uint32_t failures = 0;    ///< Ended with an error (timeout, device error, ...).
  std::uint32_t wrong = 0;       ///< Confirmed with values other than those sent (undetected corruption).
  std::uint64_t bytes_to_device = 0;    ///< Bytes the host wrote.
  std::uint64_t bytes_from_device = 0;  ///< Bytes the host read.
  std::uint64_t bits_flipped = 0;       ///< Noise injected, both directions.
  double latency_p50_ms = 0;  ///< Median operation time (wall clock; percentiles to 0.5 %, bounded memory).
  double latency_p99_ms = 0;  ///< 99th percentile.
  double latency_max_ms = 0;  ///< Slowest.
  // The link's counters below cover the device's whole session, its opening included (as a capture of the
  // run does).
  std::uint32_t retries = 0;     ///< Re-sends by the session engine.
  std::uint32_t stale = 0;       ///< Replies that matched no call (dropped).
  std::uint32_t crc_errors = 0;  ///< Frames dropped by the checksum.
  std::uint32_t framing_errors = 0;  ///< Frames dropped as malformed.
  std::uint32_t resyncs = 0;  ///< Times the decoder dropped bytes to catch the next frame (a Romi frame cut by a new `#`).
  std::uint32_t resets_injected = 0;  ///< Power cycles injected.
  /// Resets the host detected (proxy: session change). Unset: the protocol cannot tell.
  std::optional<std::uint32_t> resets_detected;
  /// Wall time from the reset to the next confirmed operation. Unset: no reset, never recovered, or the
  /// protocol does not confirm.
  std::optional<double> recovery_ms;
  /// Unconfirmed protocols (proxy-compat): writes of the last positions after the run, until the device's
  /// state stream showed them (the deployed host does not re-write; see the file overview).
  std::uint32_t final_rewrites = 0;
  /// Virtual devices: the D9/D10 pulses match the last successful operation (compat: the re-written
  /// last positions). Unset: not checkable.
  std::optional<bool> pins_match;
  std::string pins_detail;  ///< Measured vs expected pulses.
  std::string first_error;  ///< The first error seen, for the notes.
  /// Failed and wrong operations by cause (the error's kind; at most kMaxFailureCauses, then "other").
  std::map<std::string, std::uint32_t> failure_causes;
  /// Confirmed against executed, from the firmware's execution witness (exactly_once.hpp). Unset: the
  /// device has no witness (hardware, or an image without the recorder).
  std::optional<ExactlyOnce> exactly_once;
};

/// A whole run.
struct DemoReport {
  std::string rover;                   ///< The config's name.
  unsigned iterations = 0;             ///< Operations per device.
  double bit_error_rate = 0;           ///< Noise.
  bool reset_halfway = false;          ///< Resets injected.
  std::chrono::milliseconds duration{0};  ///< A timed run's length (0: `iterations` operations).
  unsigned reset_every = 0;            ///< Power cycles every this many operations (0: halfway or none).
  double wall_seconds = 0;             ///< Duration of the run (opening included).
  std::vector<DeviceReport> devices;   ///< One per device, in config order.
};

/// Opens the rover, runs the workload on every device at once, closes. Throws devices::ConfigError when
/// the rover does not open.
DemoReport run_demo(const DemoOptions& options);

/// The side-by-side table (one column per device) and notes, for a terminal.
std::string format_table(const DemoReport& report);
/// Exactly-once figures as a JSON object (null when unset): `tether demo --json` and `tether bench`.
nlohmann::json witness_json(const std::optional<ExactlyOnce>& figures);
/// The report as JSON (`tether demo --json`).
nlohmann::json to_json(const DemoReport& report);
/// `to_json` as one line of text. Device texts that are not valid UTF-8 (names, first errors quoting what a
/// device sent) are replaced with U+FFFD rather than thrown on.
std::string format_json(const DemoReport& report);

}  // namespace tether::demo
