/// @file binomial.hpp
/// Checking a count of random events (faults drawn with probability p) against its distribution, for gtest
/// tests: wide enough that a correct model practically never fails, narrow enough to catch a wrong rate.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

namespace tether::testing {

/// Expects |`observed` - n p| within 5 standard deviations of a binomial(n = `trials`, `p`), plus one for
/// rounding; `what` names the count in the failure message.
inline void expect_binomial(std::uint64_t observed, std::uint64_t trials, double p, const char* what) {
  const double mean = static_cast<double>(trials) * p;
  const double sigma = std::sqrt(static_cast<double>(trials) * p * (1.0 - p));
  EXPECT_LE(std::abs(static_cast<double>(observed) - mean), 5.0 * sigma + 1.0)
      << what << ": observed " << observed << " of " << trials << ", expected " << mean << " +- " << sigma;
}

}  // namespace tether::testing
