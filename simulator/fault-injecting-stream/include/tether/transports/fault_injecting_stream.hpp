/// @file fault_injecting_stream.hpp
/// Wraps any ByteStream and injects line faults in both directions: the same fault model as the virtual
/// Uno (bit errors, dropped and duplicated bytes, extra latency), seeded and reproducible, with counts.
///
/// Direction names follow the device: `to_device` faults hit what the host writes, `from_device` faults
/// what the host reads. Latency is added in wall time, per chunk (one write, or one read of the inner
/// stream), and never reorders bytes. A write completes with the size the caller wrote, whatever the
/// line did to it, just as a UART reports a byte as sent.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "tether/transports/byte_stream.hpp"
#include "tether/transports/fault_model.hpp"

namespace tether::transports {

/// Fault-injecting wrapper; create with `wrap`.
class FaultInjectingStream final : public ByteStream {
 public:
  /// Wraps `inner`, which the wrapper then owns (closing the wrapper closes it). Direction seeds are
  /// derived from `seed`. Throws std::invalid_argument for an invalid config.
  static std::shared_ptr<FaultInjectingStream> wrap(std::shared_ptr<ByteStream> inner, const FaultConfig& to_device,
                                                    const FaultConfig& from_device, std::uint64_t seed);

  /// Replaces the fault configuration (e.g. faults on after a clean handshake); PRNG state and counts
  /// are kept. Thread-safe.
  void set_faults(const FaultConfig& to_device, const FaultConfig& from_device);
  /// What was injected into the bytes the host wrote. Thread-safe snapshot.
  FaultCounts to_device_counts() const;
  /// What was injected into the bytes the host read. Thread-safe snapshot.
  FaultCounts from_device_counts() const;

  std::string description() const override;

  /// Constructed by `wrap` (public for std::make_shared).
  FaultInjectingStream(std::shared_ptr<ByteStream> inner, const FaultConfig& to_device,
                       const FaultConfig& from_device, std::uint64_t seed);

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override;
  void do_write(asio::const_buffer buffer, IoHandler handler) override;
  void do_close(error_code& error) override;

 private:
  void deliver(asio::mutable_buffer buffer, IoHandler handler);

  std::shared_ptr<ByteStream> inner_;
  mutable std::mutex models_mutex_;
  FaultModel to_device_;
  FaultModel from_device_;
  std::vector<std::uint8_t> scratch_;
  std::vector<std::uint8_t> arrived_;  // faulted bytes not yet handed to the reader (duplicates can overflow)
  std::vector<std::uint8_t> outgoing_;
  asio::steady_timer read_delay_;
  asio::steady_timer write_delay_;
};

}  // namespace tether::transports
