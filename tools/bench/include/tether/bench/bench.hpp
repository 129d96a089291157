/// @file bench.hpp
/// `tether bench`: the demo's workload (tether/demo/workload.hpp: set the servos, get the confirmation; on
/// a ring, a request round the ring) swept over line noise and request rates on every device of a rover,
/// with the figures a team needs to pick a protocol per device; or a read instead, and the smallest or the
/// largest operation of either kind (workloads.hpp: `--workload`, `--payload`).
///
/// The rover opens once; each sweep point (a bit error rate and a rate) then runs the workload on every
/// selected device at once, or one device at a time (`isolated`), and takes its figures from the
/// difference of the counters before and after the point. Before the first point the devices idle for
/// `idle_baseline` so the boards' background CPU (timer ticks, pings, state streams) can be told apart from
/// the operations' own. A rate is an open-loop schedule (one operation
/// every 1/rate s, or at once when the previous one took longer); `max` is the closed loop (the next
/// operation as soon as the previous ended), whose throughput is the device's saturation rate.
///
/// On virtual boards the device CPU comes from the simulated Unos' awake-cycle counters
/// (`transports::VirtualUnoStats::awake_cycles`): cycles executed, sleep left out, over the point, per
/// operation (the codec, the servo drivers and the background ticks and pings during the point).
///
/// Every figure is measured in the run; nothing is estimated.
#pragma once

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tether/bench/workloads.hpp"
#include "tether/demo/exactly_once.hpp"
#include "tether/devices/config.hpp"

namespace tether::bench {

/// The success share a rate must hold to count as sustained (99 %).
inline constexpr double kSustainedSuccess = 0.99;
/// The share of an asked rate a ramp step must achieve to count as sustained: below it the device (or the
/// blocking request/reply) cannot keep up, whatever its success share.
inline constexpr double kSustainedThroughput = 0.95;

/// What to run.
struct BenchOptions {
  /// The operation measured (workloads.hpp); devices without it are listed in BenchReport::skipped and
  /// not measured.
  WorkloadKind workload = WorkloadKind::servo;
  /// Its size: the demo's operation, or the smallest / largest of its kind (workloads.hpp).
  Payload payload = Payload::demo;
  /// The rover; default (unset): the embedded virtual rover (devices::default_virtual_rover_config()).
  std::optional<devices::RoverConfig> config;
  /// Firmware folder for the embedded config's image names.
  std::filesystem::path firmware_dir;
  /// Devices to measure, by name; empty: all. (The others are opened but left idle.)
  std::vector<std::string> devices;
  /// Bit error rates swept (both directions of every measured host link).
  std::vector<double> bit_error_rates{0.0, 1e-4};
  /// Rates swept, operations per second per device; unset: `max` (closed loop).
  std::vector<std::optional<double>> rates{50.0};
  /// Operations per device and point (when `duration` is unset).
  unsigned iterations = 100;
  /// Time per device and point instead of a count.
  std::optional<std::chrono::milliseconds> duration;
  /// Seed of the noise (each link gets seed, seed + 1, ... in config order).
  std::uint64_t seed = 1;
  /// One device at a time (no other traffic on the machine) rather than all at once.
  bool isolated = false;
  /// Power-cycle each virtual device halfway through every point (detection and recovery time).
  bool reset = false;
  /// How long a board stays powered off in a reset.
  std::chrono::milliseconds power_off{100};
  /// How long the devices idle after opening to measure their background CPU (virtual boards).
  std::chrono::milliseconds idle_baseline{300};
  /// After the sweep, per device and bit error rate: a saturation ramp (`--saturation`), open-loop rates
  /// `ramp_start_hz`, twice that, ... at most `ramp_steps` of them, stopping at the first step that is not
  /// sustained (< 99 % success or < 95 % of the asked rate achieved). Each step runs `iterations` (or
  /// `duration`), like a sweep point.
  bool saturation_ramp = false;
  double ramp_start_hz = 10.0;  ///< The ramp's first rate.
  unsigned ramp_steps = 7;      ///< At most this many steps (10 Hz .. 640 Hz by default).
  /// The Tether version written into the report.
  std::string tether_version;
  /// Progress after each device and point: (done, total) in device-points. May be empty.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// A firmware image behind a virtual device.
struct FirmwareImage {
  std::string path;             ///< The .elf file.
  std::string sha256;           ///< Of the file, hex.
  std::uint64_t flash_bytes = 0;  ///< .text + .data: what the image takes in flash.
  std::uint64_t ram_bytes = 0;    ///< .data + .bss + .noinit: static RAM, as avr-size counts it.
};

/// One device at one sweep point.
struct PointResult {
  std::string device;               ///< Name in the config.
  WorkloadKind workload = WorkloadKind::servo;  ///< The operation measured.
  Payload payload = Payload::demo;  ///< Its size.
  double bit_error_rate = 0;        ///< The point's noise.
  std::optional<double> rate_hz;    ///< The point's rate; unset: max (closed loop).
  std::uint32_t operations = 0;     ///< Operations attempted.
  std::uint32_t successes = 0;      ///< Confirmed (compat: written) with the right values.
  std::uint32_t failures = 0;       ///< Ended with an error (timeout, device error, ...).
  std::uint32_t wrong = 0;          ///< Confirmed with other values than sent (undetected corruption).
  double seconds = 0;               ///< Wall time of the device's run at this point.
  double latency_p50_ms = 0;        ///< Median operation time.
  double latency_p90_ms = 0;        ///< 90th percentile.
  double latency_p99_ms = 0;        ///< 99th percentile.
  double latency_max_ms = 0;        ///< Slowest.
  /// Empirical CDF of the operation times: (ms, share of operations at or below), ascending, at most 50.
  std::vector<std::pair<double, double>> latency_cdf;
  std::uint64_t bytes_to_device = 0;    ///< Bytes the host wrote.
  std::uint64_t bytes_from_device = 0;  ///< Bytes the host read.
  /// Share of the line's capacity used, each way (virtual boards: their UART's byte time; a serial port:
  /// its configured baud, 10 bits a byte for 8N1). Unset: unknown (TCP bridges).
  std::optional<double> utilisation_to_device;
  std::optional<double> utilisation_from_device;  ///< See `utilisation_to_device`.
  std::uint64_t bits_flipped = 0;   ///< Noise injected, both directions.
  std::uint32_t retries = 0;        ///< Re-sends by the session engine.
  std::uint32_t timeouts = 0;       ///< Calls that ran out of time.
  std::uint32_t stale = 0;          ///< Drops: replies that matched no call.
  std::uint32_t crc_errors = 0;     ///< Drops: frames failing their checksum.
  std::uint32_t framing_errors = 0; ///< Drops: malformed frames.
  std::uint32_t oversize = 0;       ///< Drops: frames beyond the size bound.
  /// Virtual boards: CPU cycles executed (all the device's boards) per operation. Unset: hardware.
  std::optional<double> cpu_cycles_per_op;
  /// Virtual boards: `cpu_cycles_per_op` less what the boards spend awake when idle over the same
  /// simulated time (`DeviceSummary::cpu_idle_share`: ticks, pings, state streams): the operation's own cost.
  std::optional<double> cpu_cycles_per_op_above_idle;
  /// Virtual boards: share of the boards' time awake.
  std::optional<double> cpu_share;
  std::uint32_t resets_injected = 0;        ///< Power cycles injected.
  std::optional<std::uint32_t> resets_detected;  ///< By the protocol; unset: it cannot tell.
  std::optional<double> recovery_ms;        ///< From the reset to the next confirmed operation.
  std::string first_error;                  ///< The first failure, for the notes.
  /// Commands confirmed against executed at this point, from the firmware's execution witness
  /// (tether/demo/exactly_once.hpp). Unset: the device has none (hardware, an image without it).
  std::optional<demo::ExactlyOnce> exactly_once;

  /// successes / operations (0 with no operations).
  double success_share() const;
  /// Operations per second achieved.
  double throughput_hz() const;
};

/// What a device is and how far it goes.
struct DeviceSummary {
  std::string device;      ///< Name in the config.
  std::string codec;       ///< `romi`, `proxy`, `proxy-compat`, `elcano`.
  std::string transport;   ///< One-line description.
  std::string operation;   ///< What one operation is on the wire.
  bool confirmed = true;   ///< The device confirms operations (false: proxy-compat).
  std::vector<FirmwareImage> firmware;  ///< Virtual boards' images (one per distinct image).
  /// Virtual boards: share of the time awake with no operation running, measured once after opening.
  std::optional<double> cpu_idle_share;
  /// Per swept bit error rate: the highest rate (a swept one, or the closed loop's throughput) held with
  /// >= 99 % success, and the lowest swept rate that was not (where it breaks down). Unset: none.
  struct Saturation {
    double bit_error_rate = 0;                 ///< The noise.
    std::optional<double> sustained_hz;        ///< Highest rate with >= 99 % success.
    std::optional<double> breaks_down_hz;      ///< Lowest rate below 99 % success.
    /// One step of the saturation ramp (BenchOptions::saturation_ramp).
    struct RampStep {
      double rate_hz = 0;           ///< Asked.
      double achieved_hz = 0;       ///< Operations per second done.
      std::uint32_t operations = 0; ///< Attempted.
      std::uint32_t successes = 0;  ///< Confirmed with the right values.
      double latency_p99_ms = 0;    ///< 99th percentile operation time.
      bool sustained = false;       ///< >= 99 % success and >= 95 % of the asked rate achieved.
    };
    /// The ramp's steps in order (empty: no ramp). With a ramp, `sustained_hz` and `breaks_down_hz` are
    /// the ramp's (its last sustained step, the step that was not) rather than the sweep's.
    std::vector<RampStep> ramp;
    /// Why the ramp's last step was not sustained: "success" (< 99 %) or "throughput" (< 95 % of the
    /// asked rate); empty: the ramp ended sustained (the device holds the highest step).
    std::string breaks_down_because;
  };
  std::vector<Saturation> saturation;  ///< One per swept bit error rate.
};

/// A whole run.
struct BenchReport {
  std::string rover;                 ///< The config's name.
  std::string tether_version;        ///< `tether --version`.
  std::uint64_t seed = 0;            ///< Of the noise.
  unsigned iterations = 0;           ///< Per device and point (0 with a duration).
  std::optional<double> duration_s;  ///< Per device and point, instead of iterations.
  bool isolated = false;             ///< One device at a time.
  bool reset = false;                ///< Power cycles injected halfway through every point.
  bool saturation_ramp = false;      ///< A saturation ramp ran (DeviceSummary::Saturation::ramp).
  WorkloadKind workload = WorkloadKind::servo;  ///< The operation measured.
  Payload payload = Payload::demo;              ///< Its size.
  std::vector<double> bit_error_rates;          ///< Swept.
  std::vector<std::optional<double>> rates;     ///< Swept (unset: max).
  double wall_seconds = 0;           ///< The whole run.
  std::vector<DeviceSummary> devices;  ///< In config order.
  std::vector<PointResult> points;     ///< Per point (BER-major, then rate), each measured device.
  /// A device not measured because it has no such workload.
  struct Skipped {
    std::string device;  ///< Name in the config.
    std::string why;     ///< What its images lack.
  };
  std::vector<Skipped> skipped;  ///< Selected devices the workload does not apply to.
};

/// Opens the rover, runs every point, closes. Throws devices::ConfigError when the rover does not open,
/// std::invalid_argument for an unknown device name or empty sweeps.
BenchReport run_bench(const BenchOptions& options);

/// Reads an image's hash and sizes; `error` set (and nothing) when it cannot.
std::optional<FirmwareImage> describe_firmware(const std::filesystem::path& elf, std::string& error);

/// The report as JSON: every figure, the parameters, seed, firmware, version (bench.json).
nlohmann::json to_json(const BenchReport& report);
/// One row per device and point, the same figures flat (bench.csv).
std::string to_csv(const BenchReport& report);
/// A summary table for a terminal: one row per device and point.
std::string format_table(const BenchReport& report);

/// Two runs' JSON side by side (`tether bench --compare`).
struct Comparison {
  std::string text;          ///< The table, flagged differences marked `*`.
  std::size_t flagged = 0;   ///< Differences beyond the run-to-run noise.
  nlohmann::json json;       ///< The same as JSON.
};
/// Compares the points both runs have (by device, BER and rate). Throws std::invalid_argument naming what
/// is missing or malformed in either document.
Comparison compare(const nlohmann::json& a, const nlohmann::json& b);

}  // namespace tether::bench
