/// @file fault_model.hpp
/// Byte-level fault injection for serial links, shared by every transport that injects faults (the
/// virtual Uno applies it to its simulated UART, a Boost.Asio wrapper to real streams).
///
/// The model is transport-agnostic and clock-free: `apply()` turns the bytes a sender put on the line
/// into the bytes the receiver gets (dropped, duplicated, bits inverted), and `draw_latency()` says how
/// much extra delay the transport should add to a chunk. The transport decides what the delay is
/// measured in: the virtual Uno adds it in simulated time, an asio wrapper in wall time.
///
/// Reproducibility: every decision comes from one seeded PRNG (`FaultRandom`, xoshiro256** seeded
/// through splitmix64; no std:: distributions, so the sequence is identical on every platform and
/// standard library). The same seed, configuration and sequence of `apply()`/`draw_latency()` calls
/// always give the same output and the same counts, however the input is split into chunks (the
/// decisions are drawn per byte and per bit, never per chunk; only `draw_latency()` is per call).
///
/// Per input byte, in this order:
///   1. dropped with probability `drop_rate` (nothing else happens to it);
///   2. each of its 8 data bits is inverted independently with probability `bit_error_rate` (start,
///      stop and parity bits are not modelled);
///   3. delivered twice with probability `duplicate_rate` (both copies carry the same corruption).
/// Bit errors are drawn as geometric gaps between flipped bits, so a low rate costs nothing per byte.
///
/// Thread safety: none. One model per direction of a link, used from one thread at a time.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace tether::transports {

/// What to inject in one direction of a link. All rates are probabilities in [0, 1].
struct FaultConfig {
  /// Probability that a data bit is inverted (8 data bits per byte).
  double bit_error_rate = 0.0;
  /// Probability that a byte is lost.
  double drop_rate = 0.0;
  /// Probability that a (surviving) byte is delivered twice.
  double duplicate_rate = 0.0;
  /// Extra delay for every chunk (the transport decides what a chunk is; the virtual Uno: one byte).
  std::chrono::nanoseconds latency{0};
  /// Plus a delay drawn uniformly from [0, latency_jitter]. Transports keep the byte order: a chunk is
  /// never delivered before the one sent ahead of it.
  std::chrono::nanoseconds latency_jitter{0};

  /// True when any fault or delay is configured.
  bool active() const;
  /// Throws std::invalid_argument naming the bad field when a rate is outside [0, 1] (or NaN) or a
  /// delay is negative.
  void validate() const;
  /// One line, e.g. "ber=1e-05 drop=0.01 dup=0 latency=0ns+0ns".
  std::string describe() const;
};

/// What a model has done so far.
struct FaultCounts {
  std::uint64_t bytes_in = 0;          ///< bytes offered to `apply()`
  std::uint64_t bytes_out = 0;         ///< bytes `apply()` produced (in - dropped + duplicated)
  std::uint64_t bytes_dropped = 0;     ///< bytes lost
  std::uint64_t bytes_duplicated = 0;  ///< bytes delivered twice (counted once per extra copy)
  std::uint64_t bits_flipped = 0;      ///< data bits inverted
  std::uint64_t bytes_corrupted = 0;   ///< bytes with at least one inverted bit (counted once per input byte)
  std::uint64_t latency_draws = 0;     ///< calls of `draw_latency()`
  std::chrono::nanoseconds latency_total{0};  ///< sum of the delays `draw_latency()` returned

  FaultCounts& operator+=(const FaultCounts& other);
  bool operator==(const FaultCounts&) const = default;
};

/// Small, fast, platform-independent PRNG (xoshiro256**, state seeded by splitmix64). Exposed so that
/// transports derive their other seeded choices (e.g. the virtual Uno's power-up RAM) the same way.
class FaultRandom {
 public:
  explicit FaultRandom(std::uint64_t seed = 0);
  /// Next 64 random bits.
  std::uint64_t next();
  /// Uniform in [0, 1) with 53 bits of precision.
  double uniform();
  /// True with probability p (p <= 0: never, p >= 1: always).
  bool chance(double p);
  /// Uniform in [0, bound] (bound inclusive).
  std::uint64_t below_or_equal(std::uint64_t bound);
  /// Mixes a seed with a stream number (splitmix64 finaliser), for independent per-direction streams.
  static std::uint64_t mix(std::uint64_t seed, std::uint64_t stream);

 private:
  std::uint64_t state_[4];
};

/// The fault model of one direction of a link.
class FaultModel {
 public:
  /// A model that passes everything through unchanged (and still counts bytes).
  FaultModel();
  /// Throws std::invalid_argument if `config` is invalid (see FaultConfig::validate).
  FaultModel(const FaultConfig& config, std::uint64_t seed);

  /// Appends the receiver's bytes for `input` to `output`.
  void apply(std::span<const std::uint8_t> input, std::vector<std::uint8_t>& output);
  /// Same, returning a new vector.
  std::vector<std::uint8_t> apply(std::span<const std::uint8_t> input);
  /// Applies the model to a single byte: appends 0, 1 or 2 bytes to `output`.
  void apply_byte(std::uint8_t byte, std::vector<std::uint8_t>& output);

  /// Extra delay for the next chunk: `latency` plus uniform [0, latency_jitter]. Counted.
  std::chrono::nanoseconds draw_latency();

  /// Changes the configuration, keeping the PRNG state and the counts (so a run that switches faults on
  /// after a handshake stays reproducible). Throws std::invalid_argument if invalid.
  void set_config(const FaultConfig& config);
  /// Restarts the PRNG from `seed` and zeroes the counts.
  void reseed(std::uint64_t seed);

  const FaultConfig& config() const { return config_; }
  const FaultCounts& counts() const { return counts_; }

 private:
  void draw_bit_gap();

  FaultConfig config_;
  FaultRandom random_;
  FaultCounts counts_;
  // Data bits still to pass before the next flipped one (geometric gap); UINT64_MAX: never.
  std::uint64_t bits_to_next_flip_ = UINT64_MAX;
};

}  // namespace tether::transports
