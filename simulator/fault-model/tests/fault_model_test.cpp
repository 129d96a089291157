// FaultModel: the injected rates match the configured ones (bounds that hold for any seed at 5 sigma),
// the output is what the counts say, and a seed replays exactly.
#include "tether/transports/fault_model.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "tether/testing/binomial.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using ::tether::testing::expect_binomial;

std::vector<std::uint8_t> random_bytes(std::size_t count, std::uint64_t stream) {
  auto generator = testing::seeded_generator(stream);
  std::vector<std::uint8_t> bytes(count);
  for (auto& byte : bytes) byte = static_cast<std::uint8_t>(generator());
  return bytes;
}

std::uint64_t model_seed(std::uint64_t stream) { return FaultRandom::mix(testing::random_seed(), stream); }

TEST(FaultModel, InactiveModelPassesEverythingThroughAndCounts) {
  FaultModel model;
  const auto input = random_bytes(1000, 1);
  EXPECT_EQ(model.apply(input), input);
  EXPECT_EQ(model.counts().bytes_in, 1000u);
  EXPECT_EQ(model.counts().bytes_out, 1000u);
  EXPECT_FALSE(model.config().active());
  EXPECT_EQ(model.draw_latency(), 0ns);
}

TEST(FaultModel, BitErrorRateMatchesAndCountsEveryFlippedBit) {
  const double ber = 1e-3;
  FaultModel model({.bit_error_rate = ber}, model_seed(2));
  const auto input = random_bytes(200000, 2);
  const auto output = model.apply(input);
  ASSERT_EQ(output.size(), input.size());

  std::uint64_t flipped = 0;
  std::uint64_t corrupted = 0;
  std::uint64_t per_position[8] = {};
  for (std::size_t i = 0; i < input.size(); ++i) {
    const auto diff = static_cast<std::uint8_t>(input[i] ^ output[i]);
    flipped += static_cast<std::uint64_t>(std::popcount(diff));
    corrupted += diff != 0 ? 1u : 0u;
    for (unsigned bit = 0; bit < 8; ++bit) per_position[bit] += (diff >> bit) & 1u;
  }
  EXPECT_EQ(model.counts().bits_flipped, flipped);
  EXPECT_EQ(model.counts().bytes_corrupted, corrupted);
  expect_binomial(flipped, input.size() * 8, ber, "flipped bits");
  expect_binomial(corrupted, input.size(), 1.0 - std::pow(1.0 - ber, 8), "corrupted bytes");
  for (unsigned bit = 0; bit < 8; ++bit) expect_binomial(per_position[bit], input.size(), ber, "flips at one bit position");
}

TEST(FaultModel, DropRateMatchesAndTheOutputIsASubsequence) {
  const double rate = 0.05;
  FaultModel model({.drop_rate = rate}, model_seed(3));
  const auto input = random_bytes(100000, 3);
  const auto output = model.apply(input);
  expect_binomial(model.counts().bytes_dropped, input.size(), rate, "dropped bytes");
  EXPECT_EQ(output.size(), input.size() - model.counts().bytes_dropped);
  std::size_t at = 0;
  for (const std::uint8_t byte : output) {
    while (at < input.size() && input[at] != byte) ++at;
    ASSERT_LT(at, input.size()) << "output is not a subsequence of the input";
    ++at;
  }
}

TEST(FaultModel, DuplicateRateMatchesAndEveryByteComesOnceOrTwice) {
  const double rate = 0.03;
  FaultModel model({.duplicate_rate = rate}, model_seed(4));
  std::vector<std::uint8_t> input(100000);
  for (std::size_t i = 0; i < input.size(); ++i) input[i] = static_cast<std::uint8_t>(i);  // no equal neighbours
  const auto output = model.apply(input);
  expect_binomial(model.counts().bytes_duplicated, input.size(), rate, "duplicated bytes");
  std::size_t at = 0;
  std::uint64_t doubles = 0;
  for (const std::uint8_t byte : input) {
    ASSERT_LT(at, output.size());
    ASSERT_EQ(output[at++], byte);
    if (at < output.size() && output[at] == byte) {
      ++doubles;
      ++at;
    }
  }
  EXPECT_EQ(at, output.size());
  EXPECT_EQ(doubles, model.counts().bytes_duplicated);
}

TEST(FaultModel, CombinedFaultsKeepTheCountsConsistent) {
  FaultModel model({.bit_error_rate = 1e-3, .drop_rate = 0.02, .duplicate_rate = 0.02}, model_seed(5));
  const auto input = random_bytes(100000, 5);
  const auto output = model.apply(input);
  const auto& counts = model.counts();
  EXPECT_EQ(counts.bytes_in, input.size());
  EXPECT_EQ(counts.bytes_out, output.size());
  EXPECT_EQ(counts.bytes_out, counts.bytes_in - counts.bytes_dropped + counts.bytes_duplicated);
  expect_binomial(counts.bytes_dropped, counts.bytes_in, 0.02, "dropped bytes");
  const std::uint64_t survivors = counts.bytes_in - counts.bytes_dropped;
  expect_binomial(counts.bytes_duplicated, survivors, 0.02, "duplicated bytes");
  expect_binomial(counts.bits_flipped, survivors * 8, 1e-3, "flipped bits");
}

TEST(FaultModel, SameSeedReplaysExactlyWhateverTheChunking) {
  const FaultConfig config{.bit_error_rate = 1e-2, .drop_rate = 0.05, .duplicate_rate = 0.05};
  const auto input = random_bytes(20000, 6);
  FaultModel whole(config, model_seed(6));
  const auto expected = whole.apply(input);

  FaultModel chunked(config, model_seed(6));
  auto generator = testing::seeded_generator(6);
  std::vector<std::uint8_t> output;
  std::size_t at = 0;
  while (at < input.size()) {
    const std::size_t size = std::min<std::size_t>(input.size() - at, 1 + generator() % 64);
    chunked.apply(std::span(input).subspan(at, size), output);
    at += size;
  }
  EXPECT_EQ(output, expected);
  EXPECT_EQ(chunked.counts(), whole.counts());

  FaultModel other(config, model_seed(6) + 1);
  EXPECT_NE(other.apply(input), expected) << "a different seed should give different faults";
}

TEST(FaultModel, LatencyIsFixedPlusUniformJitter) {
  FaultModel fixed({.latency = 250us}, model_seed(7));
  for (int i = 0; i < 10; ++i) EXPECT_EQ(fixed.draw_latency(), 250us);

  const auto jitter = 1000000ns;
  FaultModel model({.latency = 100us, .latency_jitter = jitter}, model_seed(8));
  const int draws = 20000;
  double sum = 0;
  for (int i = 0; i < draws; ++i) {
    const auto delay = model.draw_latency();
    ASSERT_GE(delay, 100us);
    ASSERT_LE(delay, 100us + jitter);
    sum += static_cast<double>((delay - 100us).count());
  }
  const double mean = sum / draws;
  const double expected = static_cast<double>(jitter.count()) / 2.0;
  const double sigma = static_cast<double>(jitter.count()) / std::sqrt(12.0 * draws);
  EXPECT_LE(std::abs(mean - expected), 5.0 * sigma);
  EXPECT_EQ(model.counts().latency_draws, static_cast<std::uint64_t>(draws));
}

TEST(FaultModel, CertainFaultsApplyToEveryByte) {
  const std::vector<std::uint8_t> input = {0x00, 0xFF, 0x5A};
  EXPECT_EQ(FaultModel({.bit_error_rate = 1.0}, 1).apply(input), (std::vector<std::uint8_t>{0xFF, 0x00, 0xA5}));
  EXPECT_TRUE(FaultModel({.drop_rate = 1.0}, 1).apply(input).empty());
  EXPECT_EQ(FaultModel({.duplicate_rate = 1.0}, 1).apply(input),
            (std::vector<std::uint8_t>{0x00, 0x00, 0xFF, 0xFF, 0x5A, 0x5A}));
}

TEST(FaultModel, InvalidConfigurationsAreRejected) {
  EXPECT_THROW(FaultModel({.bit_error_rate = -0.1}, 1), std::invalid_argument);
  EXPECT_THROW(FaultModel({.drop_rate = 1.5}, 1), std::invalid_argument);
  EXPECT_THROW(FaultModel({.duplicate_rate = std::nan("")}, 1), std::invalid_argument);
  EXPECT_THROW(FaultModel({.latency = -1ns}, 1), std::invalid_argument);
  FaultModel model;
  EXPECT_THROW(model.set_config({.latency_jitter = -1ns}), std::invalid_argument);
}

TEST(FaultModel, SetConfigKeepsCountsAndReseedRestarts) {
  const auto input = random_bytes(1000, 9);
  FaultModel model;
  model.apply(input);
  model.set_config({.drop_rate = 1.0});
  EXPECT_TRUE(model.apply(input).empty());
  EXPECT_EQ(model.counts().bytes_in, 2000u);
  EXPECT_EQ(model.counts().bytes_dropped, 1000u);

  FaultModel a({.bit_error_rate = 0.01}, 42);
  const auto first = a.apply(input);
  a.reseed(42);
  EXPECT_EQ(a.counts().bytes_in, 0u);
  EXPECT_EQ(a.apply(input), first);
}

}  // namespace
}  // namespace tether::transports
