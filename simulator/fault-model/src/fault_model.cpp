#include "tether/transports/fault_model.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace tether::transports {

namespace {

std::uint64_t splitmix64(std::uint64_t& state) {
  state += 0x9E3779B97F4A7C15ull;
  std::uint64_t z = state;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

void check_rate(double value, const char* name) {
  if (!(value >= 0.0 && value <= 1.0)) {  // also rejects NaN
    std::ostringstream message;
    message << "FaultConfig: " << name << " must be in [0, 1], got " << value;
    throw std::invalid_argument(message.str());
  }
}

}  // namespace

bool FaultConfig::active() const {
  return bit_error_rate > 0.0 || drop_rate > 0.0 || duplicate_rate > 0.0 || latency.count() > 0 ||
         latency_jitter.count() > 0;
}

void FaultConfig::validate() const {
  check_rate(bit_error_rate, "bit_error_rate");
  check_rate(drop_rate, "drop_rate");
  check_rate(duplicate_rate, "duplicate_rate");
  if (latency.count() < 0) throw std::invalid_argument("FaultConfig: latency must not be negative");
  if (latency_jitter.count() < 0) throw std::invalid_argument("FaultConfig: latency_jitter must not be negative");
}

std::string FaultConfig::describe() const {
  std::ostringstream text;
  text << "ber=" << bit_error_rate << " drop=" << drop_rate << " dup=" << duplicate_rate
       << " latency=" << latency.count() << "ns+" << latency_jitter.count() << "ns";
  return text.str();
}

FaultCounts& FaultCounts::operator+=(const FaultCounts& other) {
  bytes_in += other.bytes_in;
  bytes_out += other.bytes_out;
  bytes_dropped += other.bytes_dropped;
  bytes_duplicated += other.bytes_duplicated;
  bits_flipped += other.bits_flipped;
  bytes_corrupted += other.bytes_corrupted;
  latency_draws += other.latency_draws;
  latency_total += other.latency_total;
  return *this;
}

FaultRandom::FaultRandom(std::uint64_t seed) {
  std::uint64_t s = seed;
  for (auto& word : state_) word = splitmix64(s);
}

std::uint64_t FaultRandom::next() {
  const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
  const std::uint64_t t = state_[1] << 17;
  state_[2] ^= state_[0];
  state_[3] ^= state_[1];
  state_[1] ^= state_[2];
  state_[0] ^= state_[3];
  state_[2] ^= t;
  state_[3] = rotl(state_[3], 45);
  return result;
}

double FaultRandom::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

bool FaultRandom::chance(double p) {
  if (p <= 0.0) return false;
  if (p >= 1.0) return true;
  return uniform() < p;
}

std::uint64_t FaultRandom::below_or_equal(std::uint64_t bound) {
  if (bound == std::numeric_limits<std::uint64_t>::max()) return next();
  const std::uint64_t range = bound + 1;
  // Rejection sampling: unbiased for any range.
  const std::uint64_t limit = std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % range;
  std::uint64_t value = 0;
  do {
    value = next();
  } while (value >= limit);
  return value % range;
}

std::uint64_t FaultRandom::mix(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t state = seed ^ (stream * 0xD6E8FEB86659FD93ull);
  return splitmix64(state);
}

FaultModel::FaultModel() : random_(0) {}

FaultModel::FaultModel(const FaultConfig& config, std::uint64_t seed) : config_(config), random_(seed) {
  config_.validate();
  draw_bit_gap();
}

void FaultModel::draw_bit_gap() {
  const double p = config_.bit_error_rate;
  if (p <= 0.0) {
    bits_to_next_flip_ = UINT64_MAX;
    return;
  }
  if (p >= 1.0) {
    bits_to_next_flip_ = 0;
    return;
  }
  // Geometric number of good bits before the next bad one: floor(ln U / ln(1-p)), U in (0, 1].
  const double u = 1.0 - random_.uniform();
  const double gap = std::floor(std::log(u) / std::log1p(-p));
  bits_to_next_flip_ = gap >= 1.8e19 ? UINT64_MAX - 1 : static_cast<std::uint64_t>(gap);
}

void FaultModel::apply_byte(std::uint8_t byte, std::vector<std::uint8_t>& output) {
  ++counts_.bytes_in;
  if (random_.chance(config_.drop_rate)) {
    ++counts_.bytes_dropped;
    return;
  }
  if (bits_to_next_flip_ != UINT64_MAX) {
    if (bits_to_next_flip_ >= 8) {
      bits_to_next_flip_ -= 8;
    } else {
      std::uint64_t position = bits_to_next_flip_;
      unsigned flips = 0;
      while (position < 8) {
        byte = static_cast<std::uint8_t>(byte ^ (1u << position));  // bit 0 is the first on the wire
        ++flips;
        draw_bit_gap();
        position = position + 1 + bits_to_next_flip_;
      }
      bits_to_next_flip_ = position - 8;
      counts_.bits_flipped += flips;
      ++counts_.bytes_corrupted;
    }
  }
  output.push_back(byte);
  ++counts_.bytes_out;
  if (random_.chance(config_.duplicate_rate)) {
    output.push_back(byte);
    ++counts_.bytes_out;
    ++counts_.bytes_duplicated;
  }
}

void FaultModel::apply(std::span<const std::uint8_t> input, std::vector<std::uint8_t>& output) {
  output.reserve(output.size() + input.size());
  for (const std::uint8_t byte : input) apply_byte(byte, output);
}

std::vector<std::uint8_t> FaultModel::apply(std::span<const std::uint8_t> input) {
  std::vector<std::uint8_t> output;
  apply(input, output);
  return output;
}

std::chrono::nanoseconds FaultModel::draw_latency() {
  std::chrono::nanoseconds delay = config_.latency;
  if (config_.latency_jitter.count() > 0) {
    delay += std::chrono::nanoseconds(
        static_cast<std::int64_t>(random_.below_or_equal(static_cast<std::uint64_t>(config_.latency_jitter.count()))));
  }
  ++counts_.latency_draws;
  counts_.latency_total += delay;
  return delay;
}

void FaultModel::set_config(const FaultConfig& config) {
  config.validate();
  const bool ber_changed = config.bit_error_rate != config_.bit_error_rate;
  config_ = config;
  if (ber_changed) draw_bit_gap();
}

void FaultModel::reseed(std::uint64_t seed) {
  random_ = FaultRandom(seed);
  counts_ = FaultCounts{};
  draw_bit_gap();
}

}  // namespace tether::transports
