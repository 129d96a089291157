/// @file workload.hpp
/// The demo's per-device workload (set the throttle and steering servos, get the confirmation; see
/// rover_demo.hpp for what it is on each codec's wire), shared with `tether bench` so that both measure the
/// very same operation.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "tether/core/counters.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/fault_injecting_stream.hpp"

namespace tether::demo {

/// Servo pulses an operation should leave on D9/D10 (0: that output is not driven by the workload).
struct Pulses {
  std::uint16_t d9 = 0;   ///< Throttle pulse (us).
  std::uint16_t d10 = 0;  ///< Steering pulse (us).
  /// How far a measured pulse may be from these and still show this command (us): less than half the
  /// step between two commands the workload can send, so no other command passes for this one.
  double tolerance_us = 2.0;
};

/// How one operation ended.
struct Outcome {
  bool ok = false;       ///< Confirmed with the values sent.
  bool wrong = false;    ///< Confirmed, but with other values.
  std::string error;     ///< Why not ok.
  std::string cause;     ///< The error's kind, from a small set (failure_causes); empty: `error` is one.
  Pulses expected;       ///< Pulses after it (meaningful when ok).
  /// The device commands it issued: witness key (execution_witness.hpp) and whether the caller was told
  /// it succeeded.
  std::vector<std::pair<std::uint32_t, bool>> commands;
};

/// One codec's way of doing the operation.
class Workload {
 public:
  virtual ~Workload() = default;
  /// What one operation is on the wire.
  virtual std::string operation() const = 0;
  /// Runs operation `i` (blocking).
  virtual Outcome run(unsigned i) = 0;
  /// The client's link counters.
  virtual LinkCounters link() const = 0;
  /// Resets detected by the protocol (unset: it cannot tell).
  virtual std::optional<std::uint32_t> resets_detected() const { return std::nullopt; }
  /// False when a success only means "written" (nothing tells when the device works again).
  virtual bool confirms() const { return true; }
  /// After the run (noise off): makes the device's final state deterministic when the protocol cannot
  /// confirm, and returns the pulses it should show then (unset: nothing to do, the last success stands).
  /// `rewrites` counts the writes it needed.
  virtual std::optional<Pulses> settle(std::uint32_t& /*rewrites*/) { return std::nullopt; }
};

/// Opens `config` with every device's host link wrapped in a `transports::FaultInjectingStream` (which also
/// counts the wire bytes), clean while opening (handshakes, inits): a workload turns the noise on.
/// `links[k]` is device k's (config order); link k's noise is seeded `seed + k`. Throws as
/// `devices::open_rover`.
devices::Rover open_rover_with_fault_links(const devices::RoverConfig& config,
                                           const boost::asio::any_io_executor& executor, std::uint64_t seed,
                                           std::vector<std::shared_ptr<transports::FaultInjectingStream>>& links);

/// Which operation a run measures (`tether bench --workload`; the demo's is `servo`).
enum class WorkloadKind {
  servo,   ///< Drive outputs and get the confirmation (a ring: a request round the ring).
  sensor,  ///< Read a value back from the device (tether/bench/workloads.hpp says what, per codec).
};
/// `servo` / `sensor`.
const char* to_string(WorkloadKind kind);

/// The size of the operation measured (`tether bench --payload`; the demo's is `demo`).
enum class Payload {
  demo,   ///< The demo's own operation (Romi S / A, proxy 2 x ServoControl, Elcano drive).
  small,  ///< The smallest operation of the kind.
  large,  ///< The largest operation of the kind.
};
/// `demo` / `small` / `large`.
const char* to_string(Payload payload);

/// The throttle pulse of operation `i` (us): spread over 1100..1899, different from one operation to the next.
inline std::uint16_t throttle_us(unsigned i) { return static_cast<std::uint16_t>(1100 + (i * 73u) % 800u); }
/// The steering pulse of operation `i` (us), like `throttle_us` with another stride.
inline std::uint16_t steering_us(unsigned i) { return static_cast<std::uint16_t>(1100 + (i * 131u) % 800u); }
/// A servo position of operation `i` (degrees 0..180), `stride` degrees from the last.
inline std::int32_t degrees(unsigned i, unsigned stride) { return static_cast<std::int32_t>((i * stride) % 181u); }

/// One codec's workloads: how its devices do each operation. Built-in codecs' come from their plugins
/// (`tether_codec_plugin(... WORKLOADS ...)`); a codec registered at run time adds its own
/// (`register_workloads`).
struct CodecWorkloads {
  /// The codec's name (its devices row's).
  std::string_view name;
  /// The operation of `kind` and `payload` on `device` (`config`: its entry in the rover's configuration).
  /// Null, with `why` set, when the device cannot do it; may throw `std::invalid_argument` for a device
  /// configured without what the operation needs.
  std::function<std::unique_ptr<Workload>(const devices::RoverDevice& device, const devices::DeviceConfig& config,
                                          WorkloadKind kind, Payload payload, std::string& why)>
      make;
};

/// The workloads of `codec`, or null when it has none.
const CodecWorkloads* codec_workloads(devices::Codec codec);
/// Adds a codec's workloads (for start-up, before a demo or bench runs). Throws `std::invalid_argument`
/// when `workloads.name` already has some or `make` is unset.
void register_workloads(CodecWorkloads workloads);

namespace detail {
/// The workloads of every codec plugin that has them (generated from plugin_workloads.cpp.in).
std::vector<CodecWorkloads> plugin_workload_rows();
}  // namespace detail

/// The operation of `kind` and `payload` on `device`; null, with `why` set, when its codec has none or the
/// device cannot do it.
std::unique_ptr<Workload> make_workload(const devices::RoverDevice& device, const devices::DeviceConfig& config,
                                        WorkloadKind kind, Payload payload, std::string& why);

/// The demo's workload on the device (servo, demo payload: the demo drives servos the way each client
/// can). Throws std::invalid_argument for a codec without one or a proxy device without a servo init.
std::unique_ptr<Workload> make_workload(const devices::RoverDevice& device, const devices::DeviceConfig& config);

}  // namespace tether::demo
