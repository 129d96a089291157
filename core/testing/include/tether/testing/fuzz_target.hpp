/// @file fuzz_target.hpp
/// Conventions of Tether's fuzz targets. Each decoder has one: a file defining
/// `extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)` that feeds `data` to the
/// decoder and checks its invariants with `TETHER_FUZZ_CHECK`, which aborts (a finding) when one breaks.
///
/// The same file builds two ways (cmake/fuzz.cmake):
///   - in every build, linked with a driver (core/testing/src/fuzz_driver.cpp) that runs the target's
///     corpus (fuzz/corpus-NAME.tar.xz, unpacked by the build) plus seeded random inputs and mutations; a
///     ctest test, honours RANDOM_SEED;
///   - with clang and libFuzzer for coverage-guided runs: `tools/fuzz <target> [seconds]`, or every target
///     in turn with a table of execs, edges, corpus size and crashes: `tools/fuzz --all --minutes N`. That
///     build instruments every library a target links (coverage feedback, ASan, UBSan halting).
/// Targets that hold state (device loops, host clients) take commands from the input after an escape byte
/// (clock steps, operations, "let it catch up"), and check that every operation completes exactly once and
/// that nothing grows without bound; the host clients run on `FuzzLink` (fuzz_link.hpp).
#pragma once

#include <cstdio>
#include <cstdlib>

/// Aborts with a message when `condition` is false: a fuzzing finding, never a recoverable error.
#define TETHER_FUZZ_CHECK(condition)                                                            \
  do {                                                                                          \
    if (!(condition)) {                                                                         \
      std::fprintf(stderr, "fuzz invariant broken: %s (%s:%d)\n", #condition, __FILE__, __LINE__); \
      std::abort();                                                                             \
    }                                                                                           \
  } while (false)
