// Cost of the session engine's bookkeeping per call on the host: begin + reply, with 1 slot (Romi) and
// 8 slots (proxy-style pipelining).
#include <benchmark/benchmark.h>

#include <cstdint>

#include "tether/core/session/duplicate_filter.hpp"
#include "tether/core/session/request_table.hpp"

namespace {

struct BytePolicy {
  using Id = uint8_t;
  using Code = int16_t;
  static bool is_success(Code code) { return code >= 0; }
  static bool is_retryable(Code code) { return code < 0 && code >= -6; }
};
struct WordPolicy {
  using Id = uint32_t;
  using Code = uint8_t;
  static bool is_success(Code) { return true; }
  static bool is_retryable(Code) { return false; }
};

template <typename Policy, uint8_t Capacity>
void BM_RequestTableCall(benchmark::State& state) {
  tether::LinkCounters counters;
  tether::session::RequestTable<Policy, Capacity> table(tether::session::CallTiming(), 0, counters);
  // Keep Capacity-1 calls in flight so lookups scan a full table.
  for (uint8_t i = 1; i < Capacity; ++i) (void)table.begin(0);
  tether::Millis now = 0;
  auto* escaped = &table;
  benchmark::DoNotOptimize(escaped);
  for (auto _ : state) {
    const auto id = table.begin(now);
    benchmark::DoNotOptimize(table.on_reply(id.value(), 0, now));
    // The table lives in memory between calls, as in a client; without the escape and this the compiler
    // folds a one-slot table's begin + reply into registers and the row measures nothing.
    benchmark::ClobberMemory();
    ++now;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_RequestTableCall<BytePolicy, 1>);
BENCHMARK(BM_RequestTableCall<WordPolicy, 8>);

void BM_DuplicateFilterCheckAndRemember(benchmark::State& state) {
  tether::LinkCounters counters;
  tether::session::DuplicateFilter<uint8_t, 1, 64> filter(counters);
  const tether::ByteView reply = tether::ByteView::from_literal("#e[0,1,2]:00dc\r\n");
  uint8_t id = 0;
  auto* escaped = &filter;
  benchmark::DoNotOptimize(escaped);
  for (auto _ : state) {
    benchmark::DoNotOptimize(filter.check(id, id));
    filter.remember(id, id, reply);
    benchmark::ClobberMemory();
    ++id;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_DuplicateFilterCheckAndRemember);

}  // namespace
