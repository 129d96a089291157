/// @file eventually.hpp
/// Waiting for a condition another thread makes true (a client's strand, a fake device): the one polling
/// helper of every test. Only an upper bound on the wait, never a timing assertion: a loaded machine makes
/// it slower, not wrong.
#pragma once

#include <chrono>
#include <thread>

namespace tether::testing {

/// Default bound of `eventually`: generous, so that only a condition that never holds fails (ASan and a
/// busy machine included).
inline constexpr std::chrono::milliseconds kEventuallyTimeout{10000};  // held at load 25 on 2 cores (ASan)

/// Waits until `predicate()` is true, polling every 5 ms, at most `timeout`; returns the last value.
template <typename Predicate>
bool eventually(Predicate predicate, std::chrono::milliseconds timeout = kEventuallyTimeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!predicate()) {
    if (std::chrono::steady_clock::now() >= deadline) return predicate();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace tether::testing
