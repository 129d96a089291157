// The arm schema's device on the host, for the client tests: the service code `tether generate` writes
// for arm.proto, the real device runtime (codecs/rpc/device) and nanopb. No nanopb type crosses this header, so a test includes it beside libprotobuf's classes of
// the same schemas. Not thread-safe: its owner serialises the calls.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "tether/core/time.hpp"

namespace tether::rpc::testing {

/// One arm device: MoveJoint answers `reached_cdeg = angle_cdeg - 1` (or the error set with
/// `fail_moves`), Watch fills `angles_cdeg = [watches, -watches]` and `millis = now`.
class ArmDevice {
 public:
  /// Device whose hello carries `schema_hash`, writing each frame it sends to `output`.
  ArmDevice(std::uint64_t schema_hash, std::function<void(std::string frame)> output);
  ~ArmDevice();
  ArmDevice(const ArmDevice&) = delete;
  ArmDevice& operator=(const ArmDevice&) = delete;

  /// A boot: a fresh runtime (no streams, nothing remembered) in session `session`; sends ResetEvent.
  void boot(std::uint32_t session, Millis now);
  /// Bytes from the host.
  void feed(const std::uint8_t* data, std::size_t size, Millis now);
  /// The runtime's poll (streams, hello, failsafe).
  void poll(Millis now);

  /// From now on MoveJoint answers `Status::error(code, text)` (code 0: answers again).
  void fail_moves(std::uint16_t code, std::string text);
  /// MoveJoint runs (each call once, whatever the re-sends).
  int moves() const;
  /// The last MoveJoint's angle.
  std::int32_t last_angle() const;
  /// Watch's runs.
  int watches() const;
  /// The runtime's counters: duplicates answered from the cache, refusals, stream messages sent.
  std::uint32_t duplicates() const;
  std::uint32_t refused() const;
  std::uint32_t stream_messages() const;
  /// Streams the runtime is running.
  int open_streams() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace tether::rpc::testing
