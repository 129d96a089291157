// Throughput of the host CRC back end (tables computed by Boost.CRC, eight bytes per step) on frame-sized
// buffers, as a run and fed byte by byte.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "tether/core/crc.hpp"

namespace {

std::vector<uint8_t> buffer_of(int64_t size) {
  std::vector<uint8_t> data(static_cast<size_t>(size));
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 31u + 7u);
  return data;
}

template <typename Crc>
void BM_Crc(benchmark::State& state) {
  const auto data = buffer_of(state.range(0));
  const tether::ByteView view(data.data(), data.size());
  for (auto _ : state) benchmark::DoNotOptimize(Crc::compute(view));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}

// Byte-at-a-time, as an incremental decoder feeds it.
template <typename Crc>
void BM_CrcBytewise(benchmark::State& state) {
  const auto data = buffer_of(state.range(0));
  for (auto _ : state) {
    Crc crc;
    for (uint8_t byte : data) crc.update(byte);
    benchmark::DoNotOptimize(crc.value());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}

BENCHMARK(BM_Crc<tether::Crc8Smbus>)->Arg(64)->Arg(256)->Arg(4096);
BENCHMARK(BM_Crc<tether::Crc16Mcrf4xx>)->Arg(64)->Arg(256)->Arg(4096);
BENCHMARK(BM_CrcBytewise<tether::Crc8Smbus>)->Arg(64);
BENCHMARK(BM_CrcBytewise<tether::Crc16Mcrf4xx>)->Arg(64);

}  // namespace
