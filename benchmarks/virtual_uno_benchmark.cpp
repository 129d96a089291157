// How fast the virtual Uno simulates in fast mode: the "sim_seconds" counter is simulated seconds per wall
// second. Run: build/benchmarks/tether_virtual_uno_benchmarks (sim_Mcycles: simulated megacycles per wall second)
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "tether/transports/virtual_uno.hpp"

namespace {

using namespace std::chrono_literals;
using tether::transports::CpuState;
using tether::transports::Pacing;
using tether::transports::VirtualUno;
using tether::transports::VirtualUnoGroup;
using tether::transports::VirtualUnoOptions;

VirtualUnoOptions options(const char* image) {
  VirtualUnoOptions result;
  result.firmware = std::filesystem::path(TETHER_FIRMWARE_DIR) / image;
  result.pacing = Pacing::fast;
  return result;
}

void report(benchmark::State& state, double simulated_seconds, std::uint64_t cycles) {
  state.counters["sim_seconds"] = benchmark::Counter(simulated_seconds, benchmark::Counter::kIsRate);
  state.counters["sim_Mcycles"] = benchmark::Counter(static_cast<double>(cycles) / 1e6, benchmark::Counter::kIsRate);
}

// echo.elf with nothing to do: asleep between its 1 kHz timer ticks.
void BM_EchoIdle(benchmark::State& state) {
  VirtualUno uno(options("echo.elf"));
  uno.run_for(10ms);
  const auto start = uno.cycles();
  for (auto _ : state) uno.run_for(1s);
  report(state, static_cast<double>(state.iterations()), uno.cycles() - start);
}
BENCHMARK(BM_EchoIdle)->Unit(benchmark::kMillisecond);

// echo.elf echoing at full line rate both ways (~10.7 kB/s in, the same out).
void BM_EchoSaturated(benchmark::State& state) {
  VirtualUno uno(options("echo.elf"));
  uno.set_output_handler([](const std::uint8_t*, std::size_t) {});
  uno.run_for(10ms);
  const std::string chunk(11000, 'x');  // a little more than a second's worth
  const auto start = uno.cycles();
  for (auto _ : state) {
    uno.write(chunk);
    uno.run_for(1s);
  }
  report(state, static_cast<double>(state.iterations()), uno.cycles() - start);
}
BENCHMARK(BM_EchoSaturated)->Unit(benchmark::kMillisecond);

// avr-selftest.elf's printing phase: CRCs and a UART polled in a busy loop, the CPU never sleeps.
void BM_BusyFirmware(benchmark::State& state) {
  double simulated = 0;
  std::uint64_t cycles = 0;
  for (auto _ : state) {
    state.PauseTiming();
    VirtualUno uno(options("avr-selftest.elf"));
    state.ResumeTiming();
    while (uno.cpu_state() != CpuState::halted) uno.run_for(10ms);
    simulated += std::chrono::duration<double>(uno.simulated_time()).count();
    cycles += uno.cycles();
  }
  report(state, simulated, cycles);
}
BENCHMARK(BM_BusyFirmware)->Unit(benchmark::kMillisecond);

// Two idle echo boards wired in lockstep (64 us quantum): the cost of the group.
void BM_RingOfTwoIdle(benchmark::State& state) {
  VirtualUno a(options("echo.elf"));
  VirtualUno b(options("echo.elf"));
  VirtualUnoGroup ring(Pacing::fast);
  ring.add(a);
  ring.add(b);
  ring.connect(a, b);
  b.set_output_handler([](const std::uint8_t*, std::size_t) {});
  ring.run_for(10ms);
  const auto start = a.cycles();
  for (auto _ : state) ring.run_for(1s);
  report(state, static_cast<double>(state.iterations()), a.cycles() - start);
}
BENCHMARK(BM_RingOfTwoIdle)->Unit(benchmark::kMillisecond);

// A closed ring of two echo boards: their banners circulate for ever, both boards at full line rate.
void BM_ClosedRingOfTwoSaturated(benchmark::State& state) {
  VirtualUno a(options("echo.elf"));
  VirtualUno b(options("echo.elf"));
  VirtualUnoGroup ring(Pacing::fast);
  ring.add(a);
  ring.add(b);
  ring.connect(a, b);
  ring.connect(b, a);
  ring.run_for(10ms);
  const auto start = a.cycles();
  for (auto _ : state) ring.run_for(1s);
  report(state, static_cast<double>(state.iterations()), a.cycles() - start);
}
BENCHMARK(BM_ClosedRingOfTwoSaturated)->Unit(benchmark::kMillisecond);

}  // namespace
