/// @file workload.hpp
/// The demo's per-device workload (set the throttle and steering servos, get the confirmation; see
/// rover_demo.hpp for what it is on each codec's wire), shared with `tether bench` so that both measure the
/// very same operation.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
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

/// The workload of the device's client (the demo drives servos the way each client can). Throws
/// std::invalid_argument for a codec without one or a proxy device without a servo init.
std::unique_ptr<Workload> make_workload(const devices::RoverDevice& device, const devices::DeviceConfig& config);

/// A sensor read on the device's client, beside the servo workload (`tether bench --workload sensor`):
/// Romi `A[channel]` -> `[0, value]` (an ADC reading 0..1023 of A0..A5, cycling; a value out of range or
/// another shape is a wrong answer). Null, with `why` set, for the other codecs: their reads are not a
/// request with an answer (the proxy reports a pin's state after a control, an Elcano ring answers a goal
/// with the drive node's report), so `tether bench` builds them itself (tools/bench workloads.hpp).
std::unique_ptr<Workload> make_sensor_workload(const devices::RoverDevice& device, std::string& why);

}  // namespace tether::demo
