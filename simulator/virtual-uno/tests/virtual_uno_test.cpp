// The virtual Uno with the real images: echo.elf (banner, then echoes every byte) and avr-selftest.elf
// (prints, then halts). Deterministic tests drive the simulation with run_for(); the others run it on its
// thread in fast mode and wait in wall time with generous limits (they normally take milliseconds).
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "test_support.hpp"
#include "tether/testing/binomial.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using ::tether::testing::expect_binomial;
using test::ChildProcess;
using test::count_occurrences;
using test::echo_options;
using test::firmware_path;
using test::kEchoBanner;
using test::OutputRecorder;
using test::PtyClient;
namespace reg = atmega328p;

constexpr auto kWallLimit = 30s;  // only reached when something is broken

std::string random_payload(std::size_t size, std::uint64_t stream) {
  auto generator = testing::seeded_generator(stream);
  std::string payload(size, '\0');
  for (auto& byte : payload) byte = static_cast<char>(generator());
  return payload;
}

std::function<void(SimDuration)> stepper(VirtualUno& uno) {
  return [&uno](SimDuration step) { uno.run_for(step); };
}

// Runs `uno` (not started) until its banner has arrived at `recorder`.
void boot(VirtualUno& uno, OutputRecorder& recorder, std::size_t banners = 1) {
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return count_occurrences(recorder.text(), kEchoBanner) >= banners; },
                              1s))
      << "no banner; got '" << recorder.text() << "'";
}

// --- the byte stream -----------------------------------------------------------------------------------

TEST(VirtualUnoEcho, BannerComesFirstThenEveryByteValueRoundTripsInProcess) {
  VirtualUno uno(echo_options());
  uno.start();
  EXPECT_TRUE(uno.running());
  EXPECT_EQ(test::read_until(uno, kEchoBanner, kWallLimit), kEchoBanner);

  std::string payload;
  for (int value = 0; value < 256; ++value) payload.push_back(static_cast<char>(value));
  payload += random_payload(744, 1);
  uno.write(payload);
  std::string echoed;
  std::uint8_t buffer[512];
  const auto deadline = std::chrono::steady_clock::now() + kWallLimit;
  while (echoed.size() < payload.size() && std::chrono::steady_clock::now() < deadline) {
    echoed.append(reinterpret_cast<const char*>(buffer), uno.read(buffer, 100ms));
  }
  EXPECT_EQ(echoed, payload);
  uno.stop();
  EXPECT_FALSE(uno.running());
  const auto stats = uno.stats();
  EXPECT_EQ(stats.rx_bytes, payload.size());
  EXPECT_EQ(stats.rx_bytes_lost, 0u);
  EXPECT_EQ(stats.tx_bytes, kEchoBanner.size() + payload.size());
  EXPECT_EQ(uno.available(), 0u);
}

TEST(VirtualUnoEcho, RoundTripsThroughItsPty) {
  VirtualUno uno(echo_options());
  const std::string path = uno.open_pty();  // before start: the boot output waits in the pty
  EXPECT_EQ(uno.pty_path(), path);
  EXPECT_EQ(uno.open_pty(), path) << "a second call returns the open pty";
  uno.start();
  {
    PtyClient client(path);
    ASSERT_TRUE(client.is_open()) << path;
    EXPECT_EQ(client.read_until(kEchoBanner, kWallLimit), kEchoBanner);
    client.write("hello over the pty\r\n");
    EXPECT_EQ(client.read_until("\r\n", kWallLimit), "hello over the pty\r\n");
  }
  {
    PtyClient again(path);  // clients may come and go while the board runs
    ASSERT_TRUE(again.is_open());
    again.write("second client");
    EXPECT_EQ(again.read_until("client", kWallLimit), "second client");
  }
  PtyClient watcher(path);
  ASSERT_TRUE(watcher.is_open());
  uno.stop();
  EXPECT_FALSE(uno.pty_path().has_value()) << "stop() closes the pty";
  EXPECT_TRUE(watcher.hung_up(kWallLimit)) << "a client still on the port sees the hang-up";
}

TEST(VirtualUnoEcho, OutputHandlerTakesTheBytesUntilCleared) {
  VirtualUno uno(echo_options());
  std::optional<OutputRecorder> recorder(uno);
  uno.start();
  ASSERT_TRUE(recorder->wait_for(kEchoBanner, kWallLimit));
  uno.write("to the handler");
  ASSERT_TRUE(recorder->wait_for("handler", kWallLimit));
  EXPECT_EQ(recorder->text(), std::string(kEchoBanner) + "to the handler");
  EXPECT_EQ(uno.available(), 0u) << "bytes taken by the handler do not reach read()";
  recorder.reset();  // clears the handler; from now on read() gets the bytes
  uno.write("to read()");
  EXPECT_EQ(test::read_until(uno, "read()", kWallLimit), "to read()");
}

TEST(VirtualUnoEcho, HandlerMayWriteButNotStop) {
  VirtualUno uno(echo_options());
  std::atomic<bool> stop_refused{false};
  std::atomic<int> calls{0};
  uno.set_output_handler([&](const std::uint8_t*, std::size_t) {
    if (calls++ == 0) {
      try {
        uno.stop();
      } catch (const std::logic_error&) {
        stop_refused = true;
      }
      uno.write("x");  // allowed: queued for the next quantum
    }
  });
  uno.start();
  const auto deadline = std::chrono::steady_clock::now() + kWallLimit;
  while (uno.stats().rx_bytes < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  EXPECT_TRUE(stop_refused);
  EXPECT_EQ(uno.stats().rx_bytes, 1u);
  uno.set_output_handler({});
}

// --- I/O register watch ------------------------------------------------------------------------------------

TEST(VirtualUnoIoWatch, RecordsEveryUdr0ReadAndWriteInOrderWithoutChangingTheUart) {
  VirtualUno uno(echo_options());
  uno.watch_io(atmega328p::UDR0);
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  const std::string payload = "watch\n";
  uno.write(payload);
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return recorder.text().size() >= kEchoBanner.size() + payload.size(); }, 2s, 10ms));
  EXPECT_EQ(recorder.text(), std::string(kEchoBanner) + payload) << "the UART still works through the watch";

  const std::vector<IoAccess> accesses = uno.io_accesses(atmega328p::UDR0);
  std::string written, read;
  for (const IoAccess& access : accesses) (access.write ? written : read) += static_cast<char>(access.value);
  EXPECT_EQ(written, std::string(kEchoBanner) + payload);
  EXPECT_EQ(read, payload) << "each received byte read once, with the value the UART delivered";
  for (std::size_t i = 1; i < accesses.size(); ++i) EXPECT_LE(accesses[i - 1].cycle, accesses[i].cycle);
  // The echo writes a byte after reading it: the read of the last byte comes before its echo's write.
  const auto last_read = std::find_if(accesses.rbegin(), accesses.rend(), [](const IoAccess& a) { return !a.write; });
  ASSERT_NE(last_read, accesses.rend());
  EXPECT_TRUE(accesses.back().write);
  EXPECT_LT(last_read->cycle, accesses.back().cycle);
  EXPECT_EQ(uno.io_accesses_dropped(atmega328p::UDR0), 0u);
  EXPECT_TRUE(uno.io_accesses(atmega328p::GPIOR0).empty()) << "an unwatched register has no record";
  EXPECT_THROW(uno.watch_io(atmega328p::SREG), std::out_of_range);
}

TEST(VirtualUnoIoWatch, KeepsTheFirstLimitAccessesAndCountsTheRest) {
  VirtualUno uno(echo_options());
  uno.watch_io(atmega328p::UDR0, 4);
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  const std::vector<IoAccess> accesses = uno.io_accesses(atmega328p::UDR0);
  ASSERT_EQ(accesses.size(), 4u);
  EXPECT_EQ(std::string(1, static_cast<char>(accesses[0].value)), std::string(kEchoBanner.substr(0, 1)));
  EXPECT_EQ(uno.io_accesses_dropped(atmega328p::UDR0), kEchoBanner.size() - 4);
}

// --- timing ----------------------------------------------------------------------------------------------

TEST(VirtualUnoTiming, BulkTransferTakesElevenBitTimesPerByte) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  const std::size_t count = 2000;  // far beyond simavr's 63-byte RX FIFO
  uno.write(random_payload(count, 2));
  const std::uint64_t written_at = uno.cycles();
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return recorder.text().size() >= kEchoBanner.size() + count; }, 2s, 10ms));

  const auto uart = uno.uart();
  ASSERT_TRUE(uart.rx_enabled && uart.tx_enabled);
  EXPECT_NEAR(uart.baud, 115200.0, 115200.0 * 0.04) << "the closest a 16 MHz Uno gets to 115200";
  EXPECT_EQ(uart.cycles_per_byte, 11u * (16'000'000u / uart.baud)) << "simavr: 11 bit times per byte";

  // The echo streams back-to-back: from the first echoed byte to the last, (count - 1) byte times.
  const std::uint64_t first = recorder.cycle_of(kEchoBanner.size());
  const std::uint64_t last = recorder.cycle_of(kEchoBanner.size() + count - 1);
  const double measured = std::chrono::duration<double>(uno.to_duration(last - first)).count();
  const double wire = static_cast<double>(count - 1) * 11.0 / uart.baud;
  const double nominal = static_cast<double>(count - 1) * 11.0 / 115200.0;
  EXPECT_NEAR(measured, wire, wire * 0.01) << "11 bits per byte at the firmware's real bit rate";
  EXPECT_NEAR(measured, nominal, nominal * 0.03) << "11 bits per byte at a nominal 115200";
  // And nothing arrives faster than the wire allows: count bytes in and out take at least count byte times.
  EXPECT_GE(last - written_at, count * uart.cycles_per_byte);
  const auto stats = uno.stats();
  EXPECT_EQ(stats.rx_bytes_lost, 0u);
  EXPECT_EQ(stats.rx_bytes, count);
}

TEST(VirtualUnoTiming, RealTimePacingNeverRunsAheadOfTheWallClock) {
  auto options = echo_options();
  options.pacing = Pacing::real_time;
  VirtualUno uno(options);
  const auto began = std::chrono::steady_clock::now();
  uno.start();
  std::this_thread::sleep_for(200ms);
  const auto simulated = uno.simulated_time();
  const auto wall = std::chrono::steady_clock::now() - began;
  uno.stop();
  EXPECT_GT(simulated, 0ns);
  EXPECT_LE(simulated, wall + 5ms) << "simulated time may lead wall time by about a quantum, no more";
}

TEST(VirtualUnoTiming, TimeKeepsRunningWhenTheCpuHalts) {
  VirtualUno uno({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  OutputRecorder recorder(uno);
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return uno.cpu_state() == CpuState::halted; }, 5s, 10ms));
  EXPECT_NE(recorder.text().find("selftest end failures 00"), std::string::npos) << recorder.text();
  const auto before = uno.cycles();
  uno.run_for(1s);
  EXPECT_EQ(uno.cycles() - before, 16'000'000u);
  EXPECT_EQ(uno.simulated_time(), uno.to_duration(uno.cycles()));
}

TEST(VirtualUnoTiming, AwakeCyclesLeaveOutSleepAndHaltAndGrowWithWork) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  // Idle, echo.elf sleeps until an interrupt (Timer0's millis tick wakes it ~1000 times a second).
  auto before = uno.stats().awake_cycles;
  uno.run_for(100ms);
  const std::uint64_t idle = uno.stats().awake_cycles - before;
  EXPECT_GT(idle, 0u) << "the tick interrupts run";
  EXPECT_LT(idle, uno.to_cycles(100ms) / 20) << "asleep most of the time";
  // Echoing 200 bytes in the same 100 ms costs cycles on top of the ticks.
  before = uno.stats().awake_cycles;
  const SimDuration window_end = uno.simulated_time() + 100ms;
  uno.write(random_payload(200, 3));
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return recorder.text().size() >= kEchoBanner.size() + 200; }, 2s, 1ms));
  ASSERT_LT(uno.simulated_time(), window_end);
  uno.run_for(window_end - uno.simulated_time());
  EXPECT_GT(uno.stats().awake_cycles - before, idle + 200u * 20u) << "at least ~20 cycles per byte in and out";

  VirtualUno halted({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  ASSERT_TRUE(test::run_until(stepper(halted), [&] { return halted.cpu_state() == CpuState::halted; }, 5s, 10ms));
  before = halted.stats().awake_cycles;
  halted.run_for(100ms);
  EXPECT_EQ(halted.stats().awake_cycles, before) << "a halted CPU executes nothing";
}

// --- flow control ---------------------------------------------------------------------------------------

TEST(VirtualUnoFlowControl, InjectionWaitsWhileTheRxFifoIsFullAndResumesOnXon) {
  // The selftest halts with the receiver off; switch it on behind the firmware's back: nobody reads.
  VirtualUno uno({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return uno.cpu_state() == CpuState::halted; }, 5s, 10ms));
  const std::uint8_t ucsr0b = uno.io_read(reg::UCSR0B);
  uno.io_write(reg::UCSR0B, static_cast<std::uint8_t>(ucsr0b | 0x10));  // RXEN0
  uno.write(random_payload(100, 3));
  uno.run_for(100ms);
  auto stats = uno.stats();
  EXPECT_EQ(stats.rx_bytes, 63u) << "simavr's 64-slot FIFO holds 63 bytes; XOFF stops the injection there";
  EXPECT_EQ(stats.rx_bytes_lost, 0u);
  // Disabling the receiver flushes the FIFO; enabling it again raises XON and the rest flows in.
  uno.io_write(reg::UCSR0B, ucsr0b);
  uno.io_write(reg::UCSR0B, static_cast<std::uint8_t>(ucsr0b | 0x10));
  uno.run_for(100ms);
  stats = uno.stats();
  EXPECT_EQ(stats.rx_bytes, 100u);
  EXPECT_EQ(stats.rx_bytes_lost, 0u);
}

TEST(VirtualUnoFlowControl, BytesArrivingWhileTheReceiverIsOffAreLost) {
  VirtualUno uno({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  uno.write("early");  // the selftest never enables its receiver
  uno.run_for(10ms);
  const auto stats = uno.stats();
  EXPECT_EQ(stats.rx_bytes, 0u);
  EXPECT_EQ(stats.rx_bytes_lost, 5u);
}

// --- faults -----------------------------------------------------------------------------------------------

struct FaultRun {
  std::string received;
  VirtualUnoStats stats;
};

constexpr FaultConfig kToMcuFaults{.bit_error_rate = 1e-3, .drop_rate = 0.05, .duplicate_rate = 0.04};
constexpr FaultConfig kFromMcuFaults{.bit_error_rate = 2e-3,
                                     .drop_rate = 0.03,
                                     .duplicate_rate = 0.05,
                                     .latency = 200us,
                                     .latency_jitter = 100us};
constexpr std::size_t kFaultPayload = 4000;

// Echo with faults both ways, switched on after the banner; runs until everything is through.
FaultRun run_with_faults(std::uint64_t seed) {
  auto options = echo_options();
  options.seed = seed;
  VirtualUno uno(options);
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  uno.set_faults(Direction::to_mcu, kToMcuFaults);
  uno.set_faults(Direction::from_mcu, kFromMcuFaults);
  uno.write(random_payload(kFaultPayload, 4));
  const bool settled = test::run_until(
      stepper(uno),
      [&] {
        const auto stats = uno.stats();
        return stats.to_mcu.bytes_in == kFaultPayload && stats.rx_bytes == stats.to_mcu.bytes_out &&
               stats.tx_bytes == kEchoBanner.size() + stats.rx_bytes &&
               recorder.text().size() == stats.from_mcu.bytes_out;
      },
      3s, 10ms);
  EXPECT_TRUE(settled);
  uno.run_for(10ms);  // nothing more may come
  return FaultRun{recorder.text(), uno.stats()};
}

TEST(VirtualUnoFaults, InjectedRatesMatchTheConfigurationEndToEnd) {
  const FaultRun run = run_with_faults(FaultRandom::mix(testing::random_seed(), 10));
  const auto& stats = run.stats;
  // Everything is accounted for: host -> faults -> UART -> echo -> UART -> faults -> host.
  EXPECT_EQ(stats.to_mcu.bytes_in, kFaultPayload);
  EXPECT_EQ(stats.to_mcu.bytes_out, stats.to_mcu.bytes_in - stats.to_mcu.bytes_dropped + stats.to_mcu.bytes_duplicated);
  EXPECT_EQ(stats.rx_bytes, stats.to_mcu.bytes_out);
  EXPECT_EQ(stats.rx_bytes_lost, 0u);
  EXPECT_EQ(stats.tx_bytes, kEchoBanner.size() + stats.rx_bytes);
  EXPECT_EQ(stats.from_mcu.bytes_in, stats.tx_bytes);
  EXPECT_EQ(run.received.size(), stats.from_mcu.bytes_out);

  expect_binomial(stats.to_mcu.bytes_dropped, kFaultPayload, kToMcuFaults.drop_rate, "to_mcu drops");
  const std::uint64_t to_survivors = kFaultPayload - stats.to_mcu.bytes_dropped;
  expect_binomial(stats.to_mcu.bytes_duplicated, to_survivors, kToMcuFaults.duplicate_rate, "to_mcu duplicates");
  expect_binomial(stats.to_mcu.bits_flipped, to_survivors * 8, kToMcuFaults.bit_error_rate, "to_mcu bit errors");

  const std::uint64_t echoed = stats.from_mcu.bytes_in - kEchoBanner.size();  // faults came on after the banner
  expect_binomial(stats.from_mcu.bytes_dropped, echoed, kFromMcuFaults.drop_rate, "from_mcu drops");
  const std::uint64_t from_survivors = echoed - stats.from_mcu.bytes_dropped;
  expect_binomial(stats.from_mcu.bytes_duplicated, from_survivors, kFromMcuFaults.duplicate_rate, "from_mcu duplicates");
  expect_binomial(stats.from_mcu.bits_flipped, from_survivors * 8, kFromMcuFaults.bit_error_rate, "from_mcu bit errors");
  ASSERT_EQ(stats.from_mcu.latency_draws, from_survivors);
  const double survivors = static_cast<double>(from_survivors);
  const double mean_latency = static_cast<double>(stats.from_mcu.latency_total.count()) / survivors;
  const double jitter = static_cast<double>(kFromMcuFaults.latency_jitter.count());
  EXPECT_NEAR(mean_latency, 200e3 + jitter / 2, 5 * jitter / std::sqrt(12.0 * survivors));
}

TEST(VirtualUnoFaults, TheSameSeedReplaysTheSameFaults) {
  const std::uint64_t seed = FaultRandom::mix(testing::random_seed(), 11);
  const FaultRun first = run_with_faults(seed);
  const FaultRun second = run_with_faults(seed);
  EXPECT_EQ(first.received, second.received);
  EXPECT_EQ(first.stats.to_mcu, second.stats.to_mcu);
  EXPECT_EQ(first.stats.from_mcu, second.stats.from_mcu);
  const FaultRun other = run_with_faults(seed + 1);
  EXPECT_NE(first.received, other.received);
}

TEST(VirtualUnoFaults, ExtraLatencyDelaysDeliveryInSimulatedTime) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  // Round trip of one byte: taken at the next quantum boundary, one byte time into the UART, the
  // firmware's few microseconds, one byte time back.
  auto round_trip = [&](char byte) {
    recorder.clear();
    const std::uint64_t sent = uno.cycles();
    uno.write(std::string(1, byte));
    EXPECT_TRUE(test::run_until(stepper(uno), [&] { return !recorder.text().empty(); }, 100ms, 100us));
    return recorder.cycle_of(0) - sent;
  };
  const std::uint64_t plain = round_trip('a');
  const std::uint64_t byte_time = uno.uart().cycles_per_byte;
  EXPECT_GE(plain, 2 * byte_time);
  EXPECT_LT(plain, 2 * byte_time + uno.to_cycles(100us));
  uno.set_faults(Direction::from_mcu, {.latency = 5ms});
  const std::uint64_t delayed = round_trip('b');
  EXPECT_NEAR(static_cast<double>(delayed), static_cast<double>(plain + uno.to_cycles(5ms)),
              static_cast<double>(uno.to_cycles(100us)));
}

// --- resets ----------------------------------------------------------------------------------------------

constexpr std::uint16_t kMarkerAddress = 0x500;  // free SRAM in echo.elf (its .data+.bss end near 0x230)

std::vector<std::uint8_t> marker() {
  std::vector<std::uint8_t> bytes(64);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(0xA5 ^ (i * 7));
  return bytes;
}

TEST(VirtualUnoResets, ScheduledWatchdogResetRebootsKeepsRamAndTheStreamStaysUsable) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  uno.write_memory(kMarkerAddress, marker());
  const SimDuration at = uno.simulated_time() + 5ms;
  uno.schedule_reset(ResetKind::watchdog, at);
  boot(uno, recorder, 2);
  EXPECT_EQ(recorder.text(), std::string(kEchoBanner) + std::string(kEchoBanner));
  EXPECT_GE(uno.to_duration(recorder.cycle_of(kEchoBanner.size())), at) << "not before the scheduled time";
  EXPECT_EQ(uno.read_memory(kMarkerAddress, marker().size()), marker()) << "a watchdog reset keeps SRAM";
  auto stats = uno.stats();
  EXPECT_EQ(stats.injected_watchdog_resets, 1u);
  EXPECT_EQ(stats.boots, 2u);
  EXPECT_EQ(stats.firmware_watchdog_resets, 0u);

  recorder.clear();
  uno.write("still here");
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return recorder.text() == "still here"; }, 100ms));

  uno.reset(ResetKind::external);
  boot(uno, recorder, 1);
  stats = uno.stats();
  EXPECT_EQ(stats.injected_external_resets, 1u);
  EXPECT_EQ(stats.boots, 3u);
}

TEST(VirtualUnoResets, PowerCycleLosesInputWhileOffAndFillsSramWithSeededNoise) {
  auto power_cycle = [](std::uint64_t seed, std::string& output, VirtualUnoStats& stats) {
    auto options = echo_options();
    options.seed = seed;
    VirtualUno uno(options);
    OutputRecorder recorder(uno);
    boot(uno, recorder);
    uno.write_memory(kMarkerAddress, marker());
    uno.schedule_reset(ResetKind::power_cycle, uno.simulated_time() + 1ms, 20ms);
    EXPECT_TRUE(test::run_until(stepper(uno), [&] { return uno.cpu_state() == CpuState::powered_off; }, 10ms, 100us));
    uno.write("lost");  // nobody is there to receive it
    boot(uno, recorder, 2);
    output = recorder.text();
    stats = uno.stats();
    return uno.read_memory(kMarkerAddress, marker().size());
  };
  const std::uint64_t seed = FaultRandom::mix(testing::random_seed(), 12);
  std::string output;
  VirtualUnoStats stats;
  const auto ram = power_cycle(seed, output, stats);
  EXPECT_EQ(output, std::string(kEchoBanner) + std::string(kEchoBanner));
  EXPECT_EQ(stats.power_cycles, 1u);
  EXPECT_EQ(stats.boots, 2u);
  EXPECT_EQ(stats.rx_bytes_lost, 4u);
  EXPECT_NE(ram, marker()) << "power loss wipes SRAM";

  std::string other_output;
  VirtualUnoStats other_stats;
  EXPECT_EQ(power_cycle(seed, other_output, other_stats), ram) << "the same seed gives the same power-up RAM";
  EXPECT_NE(power_cycle(seed ^ 0x5555, other_output, other_stats), ram);
}

TEST(VirtualUnoResets, McusrTellsWhichResetHappened) {
  // The selftest never touches MCUSR, so the flags stay as the resets left them (they accumulate until
  // the firmware clears them, as on the real part; a power-on clears all but PORF).
  VirtualUno uno({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  auto mcusr = [&uno] { return uno.read_memory(reg::MCUSR, 1).at(0); };
  EXPECT_EQ(mcusr(), reg::PORF);
  uno.run_for(1ms);
  uno.reset(ResetKind::watchdog);
  uno.run_for(1ms);
  EXPECT_EQ(mcusr(), reg::PORF | reg::WDRF);
  uno.reset(ResetKind::external);
  uno.run_for(1ms);
  EXPECT_EQ(mcusr(), reg::PORF | reg::WDRF | reg::EXTRF);
  uno.reset(ResetKind::power_cycle);
  uno.run_for(1ms);
  EXPECT_EQ(mcusr(), reg::PORF);
  const auto stats = uno.stats();
  EXPECT_EQ(stats.boots, 4u);
  EXPECT_EQ(stats.injected_watchdog_resets + stats.injected_external_resets + stats.power_cycles, 3u);
}

TEST(VirtualUnoResets, FirmwareWatchdogResetRebootsTheBoard) {
  // What wdt_enable(WDTO_15MS) does, done from outside: WDCE|WDE, then WDE with WDP = 0 within 4 cycles.
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  uno.io_write(reg::WDTCSR, 0x18);
  uno.io_write(reg::WDTCSR, 0x08);
  const SimDuration armed = uno.simulated_time();
  boot(uno, recorder, 2);
  EXPECT_GE(uno.to_duration(recorder.cycle_of(kEchoBanner.size())) - armed, 15ms) << "the 16 ms watchdog period";
  auto stats = uno.stats();
  EXPECT_EQ(stats.firmware_watchdog_resets, 1u);
  EXPECT_EQ(stats.boots, 2u);
  uno.run_for(100ms);  // the runtime disarms the watchdog at boot: no reset loop
  EXPECT_EQ(uno.stats().boots, 2u);
}

TEST(VirtualUnoResets, WatchdogAlsoRebootsAHaltedCpu) {
  VirtualUno uno({.firmware = firmware_path("avr-selftest.elf"), .pacing = Pacing::fast});
  OutputRecorder recorder(uno);
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return uno.cpu_state() == CpuState::halted; }, 5s, 10ms));
  uno.io_write(reg::WDTCSR, 0x18);
  uno.io_write(reg::WDTCSR, 0x08);
  ASSERT_TRUE(test::run_until(stepper(uno), [&] { return count_occurrences(recorder.text(), "selftest begin") == 2; },
                              5s, 10ms));
  EXPECT_EQ(uno.stats().firmware_watchdog_resets, 1u);
}

// --- several boards ----------------------------------------------------------------------------------------

TEST(VirtualUnoRing, TwoEchoBoardsWithTheHostInTheRing) {
  VirtualUno first(echo_options(1));
  VirtualUno second(echo_options(2));
  VirtualUnoGroup ring(Pacing::fast);
  ring.add(first);
  ring.add(second);
  ring.connect(first, second);  // host -> first -> second -> host
  OutputRecorder host(second);
  ring.start();
  EXPECT_TRUE(first.running() && second.running());
  // The second board's banner, and the first one's echoed by the second: 2 banners' worth of bytes.
  ASSERT_TRUE(host.wait_for_size(2 * kEchoBanner.size(), kWallLimit));
  std::string banners = host.text();
  std::string expected = std::string(kEchoBanner) + std::string(kEchoBanner);
  std::sort(banners.begin(), banners.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(banners, expected);

  host.clear();
  const std::string payload = random_payload(500, 5);
  first.write(payload);
  ASSERT_TRUE(host.wait_for_size(payload.size(), kWallLimit));
  EXPECT_EQ(host.text(), payload);
  EXPECT_EQ(first.available(), 0u) << "a wired TX does not deliver to the host";
  ring.stop();
  EXPECT_EQ(second.stats().rx_bytes, kEchoBanner.size() + payload.size());
  EXPECT_THROW(first.start(), std::logic_error) << "members run through their group";
}

TEST(VirtualUnoRing, LockstepIsDeterministic) {
  auto run = [] {
    VirtualUno a(echo_options(1));
    VirtualUno b(echo_options(2));
    VirtualUno c(echo_options(3));
    VirtualUnoGroup ring(Pacing::fast, 50us);
    ring.add(a);
    ring.add(b);
    ring.add(c);
    ring.connect(a, b);
    ring.connect(b, c);
    OutputRecorder host(c);
    ring.run_for(5ms);
    a.write(random_payload(300, 6));
    ring.run_for(100ms);
    std::vector<std::pair<std::string, std::uint64_t>> batches;
    for (const auto& batch : host.batches()) batches.emplace_back(batch.bytes, batch.cycle);
    return batches;
  };
  const auto first = run();
  std::size_t bytes = 0;
  for (const auto& batch : first) bytes += batch.first.size();
  EXPECT_EQ(bytes, 3 * kEchoBanner.size() + 300);
  EXPECT_EQ(run(), first) << "same bytes at the same simulated cycles";
}

TEST(VirtualUnoRing, IndependentBoardsRunSideBySideOnTheirOwnThreads) {
  VirtualUno a(echo_options(1));
  VirtualUno b(echo_options(2));
  a.start();
  b.start();
  EXPECT_EQ(test::read_until(a, kEchoBanner, kWallLimit), kEchoBanner);
  EXPECT_EQ(test::read_until(b, kEchoBanner, kWallLimit), kEchoBanner);
  a.write("to a");
  b.write("to b");
  EXPECT_EQ(test::read_until(a, "to a", kWallLimit), "to a");
  EXPECT_EQ(test::read_until(b, "to b", kWallLimit), "to b");
}

// --- pins and peripherals ---------------------------------------------------------------------------------

TEST(VirtualUnoPins, UartPinsIdleHighAndInputsCanBeDriven) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  const PinState tx = uno.pin(uno_pins::D1);
  EXPECT_TRUE(tx.uart && tx.output && tx.level) << "TX (PD1) is the UART's and idles high";
  const PinState rx = uno.pin(uno_pins::D0);
  EXPECT_TRUE(rx.uart && !rx.output && rx.level) << "RX (PD0) is held high by the idle host line";

  const PinState idle = uno.pin(uno_pins::D2);
  EXPECT_FALSE(idle.output);
  EXPECT_TRUE(idle.floating);
  EXPECT_FALSE(idle.level);
  uno.set_input_level(uno_pins::D2, true);
  EXPECT_TRUE(uno.digital_level(uno_pins::D2));
  EXPECT_EQ(uno.port('D').pin & 0x04, 0x04) << "PIND2 follows the driven level";
  uno.run_for(1ms);
  uno.set_input_level(uno_pins::D2, false);
  const PulseTiming pulse = uno.pulse_timing(uno_pins::D2);
  EXPECT_EQ(pulse.edges, 2u);
  EXPECT_NEAR(static_cast<double>(pulse.high_time.count()), 1e6, 1e3) << "driven for 1 ms of simulated time";
  uno.release_input(uno_pins::D2);
  EXPECT_TRUE(uno.pin(uno_pins::D2).floating);

  uno.set_input_level(uno_pins::A3, true);
  EXPECT_EQ(uno.port('C').pin & 0x08, 0x08) << "A3 is PC3";
  EXPECT_THROW(uno.pin(20), std::out_of_range);
  EXPECT_THROW(uno.port('A'), std::out_of_range);
}

TEST(VirtualUnoPins, Timer1ServoPwmDrivesD9AndIsMeasured) {
  // A servo's 50 Hz: fast PWM with ICR1 as TOP (mode 14), /8, ICR1 = 39999, OCR1A = 3000 (1.5 ms).
  // echo.elf leaves Timer1 alone, so set it up the way a Servo library would.
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  uno.io_write(reg::ICR1H, 0x9C);  // 16-bit registers: high byte first
  uno.io_write(reg::ICR1L, 0x3F);
  uno.io_write(reg::OCR1AH, 0x0B);
  uno.io_write(reg::OCR1AL, 0xB8);
  uno.io_write(reg::DDRB, static_cast<std::uint8_t>(uno.port('B').ddr | 0x02));  // PB1 = D9 output
  uno.io_write(reg::TCCR1A, 0x82);  // COM1A1 | WGM11
  uno.io_write(reg::TCCR1B, 0x1A);  // WGM13 | WGM12 | CS11
  uno.run_for(200ms);
  const Timer1Registers timer = uno.timer1();
  EXPECT_EQ(timer.icr1, 39999);
  EXPECT_EQ(timer.ocr1a, 3000);
  EXPECT_EQ(timer.tccr1a, 0x82);
  const PulseTiming pulse = uno.pulse_timing(uno_pins::D9);
  EXPECT_GE(pulse.edges, 18u);
  // Edges carry the cycle at which simavr raised the pin IRQ: exact to within an instruction (a few cycles).
  EXPECT_NEAR(static_cast<double>(pulse.period.count()), 20e6, 300) << "ICR1 + 1 = 40000 ticks of 0.5 us";
  EXPECT_NEAR(static_cast<double>(pulse.high_time.count()), 1500.5e3, 300) << "OCR1A + 1 = 3001 ticks of 0.5 us";
  EXPECT_TRUE(uno.pin(uno_pins::D9).output);
}

TEST(VirtualUnoPins, AdcConvertsTheVoltageSetOnAChannel) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  auto convert = [&uno](int channel) {
    uno.io_write(reg::ADMUX, static_cast<std::uint8_t>(0x40 | channel));  // AVcc reference
    uno.io_write(reg::ADCSRA, 0xC7);                                      // ADEN | ADSC, /128
    uno.run_for(1ms);
    const unsigned low = uno.io_read(reg::ADCL);  // ADCL first, as the datasheet requires
    const unsigned high = uno.io_read(reg::ADCH);
    return static_cast<int>(low | (high << 8));
  };
  uno.set_analog_input(0, 2.5);
  uno.set_analog_input(3, 1.0);
  EXPECT_NEAR(convert(0), 512, 1);
  EXPECT_NEAR(convert(3), 205, 1);
  uno.set_analog_input(0, 5.0);
  EXPECT_EQ(convert(0), 1023);
  EXPECT_THROW(uno.set_analog_input(8, 1.0), std::out_of_range);
}

// --- EEPROM and firmware symbols ------------------------------------------------------------------------------

std::uint32_t little_endian32(const std::vector<std::uint8_t>& bytes) {
  return static_cast<std::uint32_t>(bytes.at(0) | (bytes.at(1) << 8) | (bytes.at(2) << 16)) |
         (static_cast<std::uint32_t>(bytes.at(3)) << 24);
}

TEST(VirtualUnoEeprom, StartsErasedRoundTripsAndRefusesOutOfRange) {
  VirtualUno uno(echo_options());
  EXPECT_EQ(uno.read_eeprom(0, reg::kEepromSize), std::vector<std::uint8_t>(reg::kEepromSize, 0xFF)) << "erased";
  const std::vector<std::uint8_t> block = marker();
  uno.write_eeprom(0x200, block);
  uno.write_eeprom(reg::kEepromSize - 1, std::vector<std::uint8_t>{0x5A});
  EXPECT_EQ(uno.read_eeprom(0x200, block.size()), block);
  EXPECT_EQ(uno.read_eeprom(reg::kEepromSize - 1, 1), std::vector<std::uint8_t>{0x5A});
  EXPECT_EQ(uno.read_eeprom(0x1FF, 1), std::vector<std::uint8_t>{0xFF}) << "neighbours untouched";
  EXPECT_TRUE(uno.read_eeprom(0, 0).empty());
  EXPECT_THROW(uno.write_eeprom(reg::kEepromSize - 1, std::vector<std::uint8_t>{1, 2}), std::out_of_range);
  EXPECT_THROW(static_cast<void>(uno.read_eeprom(reg::kEepromSize, 1)), std::out_of_range);

  // The accessors also work while a thread runs the board (they go through the simulation thread).
  uno.start();
  uno.write_eeprom(0x300, block);
  EXPECT_EQ(uno.read_eeprom(0x300, block.size()), block);
}

TEST(VirtualUnoEeprom, FirmwareReadsWhatTheHostWroteAndBothSurviveResets) {
  // proxy.elf counts its boots in EEPROM 0x3F8 (uint32, firmware/proxy/README.md): it reads the value
  // the host wrote before its first boot, and the host reads what it wrote back.
  constexpr std::uint16_t kBootCounter = 0x3F8;
  VirtualUno uno({.firmware = firmware_path("proxy.elf"), .pacing = Pacing::fast});
  uno.write_eeprom(kBootCounter, std::vector<std::uint8_t>{41, 0, 0, 0});
  uno.write_eeprom(0x10, marker());
  uno.run_for(50ms);
  EXPECT_EQ(little_endian32(uno.read_eeprom(kBootCounter, 4)), 42u);
  uno.reset(ResetKind::watchdog);
  uno.run_for(50ms);
  EXPECT_EQ(little_endian32(uno.read_eeprom(kBootCounter, 4)), 43u);
  uno.reset(ResetKind::power_cycle, 5ms);
  uno.run_for(60ms);
  EXPECT_EQ(uno.stats().boots, 3u);
  EXPECT_EQ(little_endian32(uno.read_eeprom(kBootCounter, 4)), 44u);
  EXPECT_EQ(uno.read_eeprom(0x10, marker().size()), marker()) << "EEPROM survives a power cycle";
}

TEST(VirtualUnoSymbols, FindsFirmwareGlobalsByName) {
  VirtualUno uno(echo_options());
  OutputRecorder recorder(uno);
  boot(uno, recorder);
  const auto main_symbol = uno.symbol("main");
  ASSERT_TRUE(main_symbol.has_value());
  EXPECT_EQ(main_symbol->space, FirmwareSymbol::Space::flash);
  EXPECT_GT(main_symbol->size, 0u);
  const auto data_start = uno.symbol("__data_start");
  ASSERT_TRUE(data_start.has_value());
  EXPECT_EQ(data_start->space, FirmwareSymbol::Space::data);
  EXPECT_EQ(data_start->address, reg::kSramStart);
  EXPECT_FALSE(uno.symbol("no_such_symbol").has_value());

  // A real use: echo's UART counters (a mangled C++ name), read without knowing where the build put them.
  const auto counters = uno.symbol("_ZN6tether8firmware5Uart0ILj128ELj128EE9counters_E");
  ASSERT_TRUE(counters.has_value());
  EXPECT_EQ(counters->space, FirmwareSymbol::Space::data);
  ASSERT_EQ(counters->size, 12u) << "rx_overflows, framing_errors, data_overruns";
  EXPECT_EQ(uno.read_memory(static_cast<std::uint16_t>(counters->address), counters->size),
            std::vector<std::uint8_t>(12, 0));
}

// --- lifecycle and errors ------------------------------------------------------------------------------------

TEST(VirtualUnoLifecycle, StopAndStartContinueAndRunForNeedsAStoppedBoard) {
  VirtualUno uno(echo_options());
  uno.start();
  uno.start();  // no-op
  EXPECT_EQ(test::read_until(uno, kEchoBanner, kWallLimit), kEchoBanner);
  EXPECT_THROW(uno.run_for(1ms), std::logic_error);
  uno.stop();
  uno.stop();  // no-op
  const auto stopped_at = uno.cycles();
  std::this_thread::sleep_for(20ms);
  EXPECT_EQ(uno.cycles(), stopped_at) << "a stopped board does not advance";
  uno.run_for(1ms);
  EXPECT_GE(uno.cycles(), stopped_at + 16000);
  uno.start();
  uno.write("again");
  EXPECT_EQ(test::read_until(uno, "again", kWallLimit), "again");
  EXPECT_EQ(uno.stats().boots, 1u);
  // The destructor stops the running board.
}

TEST(VirtualUnoLifecycle, MissingAndBadImagesAreReportedClearly) {
  const auto missing = std::filesystem::path(TETHER_FIRMWARE_DIR) / "no-such-image.elf";
  try {
    VirtualUno uno({.firmware = missing});
    FAIL() << "no exception";
  } catch (const std::system_error& error) {
    EXPECT_EQ(error.code(), std::errc::no_such_file_or_directory);
    EXPECT_NE(std::string(error.what()).find("no-such-image.elf"), std::string::npos) << error.what();
  }

  std::error_code code;
  std::string message;
  EXPECT_EQ(VirtualUno::create({.firmware = missing}, code, &message), nullptr);
  EXPECT_EQ(code, std::errc::no_such_file_or_directory);
  EXPECT_NE(message.find("no-such-image.elf"), std::string::npos);

  // Not an ELF at all: a unique temporary file, removed at the end.
  const auto text_file = std::filesystem::temp_directory_path() /
                         ("tether-virtual-uno-test-" + std::to_string(::getpid()) + ".elf");
  std::ofstream(text_file) << "this is not an ELF image\n";
  EXPECT_EQ(VirtualUno::create({.firmware = text_file}, code, &message), nullptr);
  std::filesystem::remove(text_file);
  EXPECT_EQ(code, VirtualUnoError::not_an_avr_elf);
  EXPECT_EQ(code, std::errc::executable_format_error);

  // An ELF for another machine: this very test program.
  EXPECT_EQ(VirtualUno::create({.firmware = "/proc/self/exe"}, code, &message), nullptr);
  EXPECT_EQ(code, VirtualUnoError::not_an_avr_elf);

  auto good = VirtualUno::create(echo_options(), code);
  EXPECT_FALSE(code);
  ASSERT_NE(good, nullptr);
  EXPECT_THROW(good->set_faults(Direction::to_mcu, {.drop_rate = 2.0}), std::invalid_argument);
}

std::size_t directory_entries(const char* path) {
  std::size_t count = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(path)) ++count;
  return count;
}

TEST(VirtualUnoLifecycle, LeavesNoThreadOrDescriptorBehind) {
  const std::size_t threads = directory_entries("/proc/self/task");
  const std::size_t descriptors = directory_entries("/proc/self/fd");
  {
    VirtualUno uno(echo_options());
    const std::string path = uno.open_pty();
    uno.start();
    {
      PtyClient client(path);
      EXPECT_EQ(client.read_until(kEchoBanner, kWallLimit), kEchoBanner);
    }
    uno.stop();
    uno.open_pty();
    uno.start();  // destroyed while running, with a pty open
  }
  {
    VirtualUno a(echo_options(1));
    VirtualUno b(echo_options(2));
    VirtualUnoGroup ring(Pacing::real_time);
    ring.add(a);
    ring.add(b);
    ring.connect(a, b);
    b.open_pty();
    ring.start();
    std::this_thread::sleep_for(5ms);
  }  // the group goes first, then the boards
  {
    VirtualUnoGroup ring(Pacing::fast);
    VirtualUno a(echo_options(1));
    ring.add(a);
    ring.start();
  }  // the board goes first: its destructor stops the group and leaves it
  EXPECT_EQ(directory_entries("/proc/self/task"), threads);
  EXPECT_EQ(directory_entries("/proc/self/fd"), descriptors);
}

// --- the `tether sim` command ------------------------------------------------------------------------------

TEST(TetherSim, PrintsThePtyEchoesAndCleansUpOnSigint) {
  const auto link = std::filesystem::temp_directory_path() /
                    ("tether-sim-test-" + std::to_string(::getpid()) + ".pty");
  ChildProcess sim({TETHER_TOOL_PATH, "sim", firmware_path("echo.elf").string(), "--fast", "--link", link.string()});
  const auto line = sim.read_line(kWallLimit);
  ASSERT_TRUE(line.has_value()) << sim.error_output();
  ASSERT_EQ(line->rfind("PTY ", 0), 0u) << *line;
  const std::string path = line->substr(4);
  EXPECT_EQ(std::filesystem::read_symlink(link), path);
  {
    PtyClient client(link.string());
    ASSERT_TRUE(client.is_open());
    EXPECT_EQ(client.read_until(kEchoBanner, kWallLimit), kEchoBanner);
    client.write("ping");
    EXPECT_EQ(client.read_until("ping", kWallLimit), "ping");
  }
  sim.signal(SIGINT);
  EXPECT_EQ(sim.wait(kWallLimit), 0) << sim.error_output();
  EXPECT_FALSE(std::filesystem::is_symlink(std::filesystem::symlink_status(link))) << "the link is removed";
  EXPECT_EQ(sim.read_line(100ms), std::nullopt) << "nothing but the PTY line on stdout";
}

TEST(TetherSim, HelpListsTheSubcommandsAndUnknownOnesFail) {
  ChildProcess help({TETHER_TOOL_PATH, "--help"});
  std::string listing;
  while (const auto line = help.read_line(kWallLimit)) listing += *line + "\n";
  EXPECT_EQ(help.wait(kWallLimit), 0);
  EXPECT_NE(listing.find("  sim "), std::string::npos) << listing;

  ChildProcess unknown({TETHER_TOOL_PATH, "no-such-command"});
  EXPECT_EQ(unknown.wait(kWallLimit), 2);
  EXPECT_NE(unknown.error_output().find("unknown command"), std::string::npos);

  ChildProcess usage({TETHER_TOOL_PATH, "sim", "--frobnicate"});
  EXPECT_EQ(usage.wait(kWallLimit), 2);
  EXPECT_NE(usage.error_output().find("usage: tether sim"), std::string::npos);
}

TEST(TetherSim, BadImageIsAnErrorWithExitStatusTwo) {
  ChildProcess sim({TETHER_TOOL_PATH, "sim", (std::filesystem::path(TETHER_FIRMWARE_DIR) / "missing.elf").string()});
  EXPECT_EQ(sim.wait(kWallLimit), 2);
  EXPECT_NE(sim.error_output().find("missing.elf"), std::string::npos) << sim.error_output();
  EXPECT_EQ(sim.read_line(100ms), std::nullopt);
}

}  // namespace
}  // namespace tether::transports
