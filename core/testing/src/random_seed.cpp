#include "tether/testing/random_seed.hpp"

#include <cstdio>
#include <cstdlib>
#include <string>

namespace tether::testing {

std::uint64_t random_seed() {
  static const std::uint64_t seed = [] {
    std::uint64_t value = 0;
    const char* text = std::getenv("RANDOM_SEED");
    if (text != nullptr && *text != '\0') {
      value = std::stoull(text);
    } else {
      value = (static_cast<std::uint64_t>(std::random_device{}()) << 32) ^ std::random_device{}();
    }
    std::fprintf(stderr, "RANDOM_SEED=%llu\n", static_cast<unsigned long long>(value));
    return value;
  }();
  return seed;
}

std::mt19937_64 seeded_generator(std::uint64_t stream) {
  std::seed_seq sequence{static_cast<std::uint32_t>(random_seed()), static_cast<std::uint32_t>(random_seed() >> 32),
                         static_cast<std::uint32_t>(stream), static_cast<std::uint32_t>(stream >> 32)};
  return std::mt19937_64(sequence);
}

}  // namespace tether::testing
