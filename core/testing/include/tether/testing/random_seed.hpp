/// @file random_seed.hpp
/// Reproducible randomness for tests: every randomized test takes its seed from here.
///
/// The seed is `RANDOM_SEED` from the environment when set (decimal), otherwise drawn once per process.
/// It is printed to stderr the first time it is used (`RANDOM_SEED=<n>`), so a failing run can be
/// repeated exactly: `RANDOM_SEED=<n> ctest -R <test>`.
#pragma once

#include <cstdint>
#include <random>

namespace tether::testing {

/// The process-wide seed (printed on first use).
std::uint64_t random_seed();

/// A generator seeded from `random_seed()` mixed with `stream`, so tests in one process get independent
/// but reproducible streams.
std::mt19937_64 seeded_generator(std::uint64_t stream = 0);

}  // namespace tether::testing
