// The fault-injecting wrapper over a real stream (in-memory pair): injected rates, reproducibility,
// latency, and recovery when faults are switched off.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <cmath>
#include <thread>
#include <vector>

#include "tether/testing/random_seed.hpp"
#include "tether/transports/fault_injecting_stream.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/recording.hpp"

#include <unistd.h>

#include <filesystem>
#include <string>

namespace tether::transports {
namespace {

using namespace std::chrono_literals;

std::vector<uint8_t> pattern(std::size_t size) {
  std::vector<uint8_t> bytes(size);
  for (std::size_t i = 0; i < size; ++i) bytes[i] = static_cast<uint8_t>(i * 7 + 3);
  return bytes;
}

// Writes `payload` through `writer`, then reads from `reader` until 200 ms of silence.
std::vector<uint8_t> transfer(asio::io_context& io, ByteStream& writer, ByteStream& reader,
                              const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> received;
  std::vector<uint8_t> chunk(512);
  bool finished = false;
  std::function<void()> read_on = [&] {
    reader.async_read_some(asio::buffer(chunk), SteadyClock::now() + 200ms, [&](error_code error, std::size_t size) {
      if (error) {
        finished = true;
        return;
      }
      received.insert(received.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(size));
      read_on();
    });
  };
  read_on();
  asio::async_write(writer, asio::buffer(payload), [](error_code error, std::size_t) { EXPECT_FALSE(error); });
  // Not io.run(): the reader keeps a read in flight underneath after its deadline (nothing is lost), and
  // that pending read is work, as any pending asio operation is.
  io.restart();
  while (!finished) {
    if (io.run_one() == 0) io.restart();
  }
  return received;
}

TEST(FaultInjectingStream, WithoutFaultsEveryByteArrivesUnchangedAndIsCounted) {
  asio::io_context io;
  auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor());
  auto faulty = FaultInjectingStream::wrap(host_end, FaultConfig(), FaultConfig(), 1);
  const auto payload = pattern(5000);
  EXPECT_EQ(transfer(io, *faulty, *device_end, payload), payload);
  EXPECT_EQ(faulty->to_device_counts().bytes_in, 5000u);
  EXPECT_EQ(faulty->to_device_counts().bytes_out, 5000u);
}

TEST(FaultInjectingStream, InjectedRatesMatchTheConfigurationInBothDirections) {
  const uint64_t seed = ::tether::testing::random_seed();
  FaultConfig config;
  config.bit_error_rate = 1e-3;
  config.drop_rate = 0.01;
  config.duplicate_rate = 0.005;
  constexpr std::size_t kBytes = 100000;
  const auto payload = pattern(kBytes);

  asio::io_context io;
  auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor(), 1 << 20);
  auto faulty = FaultInjectingStream::wrap(host_end, config, config, seed);
  const auto down = transfer(io, *faulty, *device_end, payload);  // host -> device
  const auto up = transfer(io, *device_end, *faulty, payload);    // device -> host

  // Binomial counts within 5 standard deviations: fails by chance far less than once in a million runs.
  const auto within = [](double count, double trials, double p) {
    return std::abs(count - trials * p) <= 5.0 * std::sqrt(trials * p * (1 - p)) + 1.0;
  };
  for (const FaultCounts& counts : {faulty->to_device_counts(), faulty->from_device_counts()}) {
    EXPECT_EQ(counts.bytes_in, kBytes);
    EXPECT_TRUE(within(static_cast<double>(counts.bytes_dropped), kBytes, config.drop_rate)) << counts.bytes_dropped;
    const double kept = static_cast<double>(kBytes - counts.bytes_dropped);
    EXPECT_TRUE(within(static_cast<double>(counts.bytes_duplicated), kept, config.duplicate_rate))
        << counts.bytes_duplicated;
    EXPECT_TRUE(within(static_cast<double>(counts.bits_flipped), kept * 8, config.bit_error_rate)) << counts.bits_flipped;
    EXPECT_EQ(counts.bytes_out, kBytes - counts.bytes_dropped + counts.bytes_duplicated);
  }
  EXPECT_EQ(down.size(), faulty->to_device_counts().bytes_out);
  EXPECT_EQ(up.size(), faulty->from_device_counts().bytes_out);
}

TEST(FaultInjectingStream, SameSeedSameDamage) {
  FaultConfig config;
  config.bit_error_rate = 1e-2;
  config.drop_rate = 0.05;
  const auto payload = pattern(3000);
  std::vector<std::vector<uint8_t>> runs;
  for (int run = 0; run < 2; ++run) {
    asio::io_context io;
    auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor(), 1 << 16);
    auto faulty = FaultInjectingStream::wrap(host_end, config, FaultConfig(), 42);
    runs.push_back(transfer(io, *faulty, *device_end, payload));
  }
  EXPECT_EQ(runs[0], runs[1]);
  EXPECT_NE(runs[0], payload);
}

TEST(FaultInjectingStream, LatencyDelaysDeliveryWithoutReordering) {
  asio::io_context io;
  auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor());
  FaultConfig slow;
  slow.latency = 30ms;
  auto faulty = FaultInjectingStream::wrap(host_end, FaultConfig(), slow, 3);
  const auto payload = pattern(64);
  const auto started = SteadyClock::now();
  std::vector<uint8_t> received(payload.size());
  SteadyClock::time_point arrived;
  asio::async_write(*device_end, asio::buffer(payload), [](error_code, std::size_t) {});
  asio::async_read(*faulty, asio::buffer(received), [&](error_code error, std::size_t) {
    EXPECT_FALSE(error);
    arrived = SteadyClock::now();
  });
  io.run();
  EXPECT_GE(arrived - started, 30ms);
  EXPECT_EQ(received, payload);
}

TEST(FaultInjectingStream, ALinkThatLosesEverythingRecoversWhenFaultsStop) {
  asio::io_context io;
  auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor());
  FaultConfig dead;
  dead.drop_rate = 1.0;
  auto faulty = FaultInjectingStream::wrap(host_end, dead, FaultConfig(), 9);
  const auto lost = transfer(io, *faulty, *device_end, pattern(100));
  EXPECT_TRUE(lost.empty());
  EXPECT_EQ(faulty->to_device_counts().bytes_dropped, 100u);
  faulty->set_faults(FaultConfig(), FaultConfig());
  EXPECT_EQ(transfer(io, *faulty, *device_end, pattern(100)), pattern(100));
  EXPECT_NE(faulty->description().find("drop=0"), std::string::npos);
}

// A recording of a noisy link (the host's end of it): the damage shows as bytes that formed no frame, in
// stream order with the frames, and nothing the host read is missing from the capture. Same seed, same
// capture.
TEST(FaultInjectingStream, ARecordingShowsTheNoiseAsUnframedBytes) {
  FaultConfig noise;
  noise.bit_error_rate = 1e-2;
  noise.drop_rate = 0.02;
  std::string lines;
  for (int i = 0; i < 100; ++i) lines += "#e[" + std::to_string(i) + ",1,2]:" + std::to_string(10 + i % 90) + "ab\r\n";
  const std::vector<uint8_t> payload(lines.begin(), lines.end());
  std::vector<Capture> captures;
  for (int run = 0; run < 2; ++run) {
    char folder[] = "/tmp/tether-noise-capture-XXXXXX";
    ASSERT_NE(::mkdtemp(folder), nullptr);
    RecordOptions options;
    options.file = std::filesystem::path(folder) / "noise.pcapng";
    auto recorder = CaptureRecorder::open(options);
    std::vector<uint8_t> received;
    {
      asio::io_context io;
      auto [host_end, device_end] = InMemoryStream::make_pair(io.get_executor(), 1 << 16);
      auto faulty = FaultInjectingStream::wrap(host_end, FaultConfig(), noise, 42);
      const CaptureFraming romi = [](bool) {
        return std::make_unique<DelimitedFramer>(DelimitedFraming::lines("#", 1032));
      };
      auto recorded = RecordingStream::wrap(faulty, recorder, "arm", "tether codec=romi baud=- transport=virtual", romi,
                                            [] { return std::uint64_t{1}; });
      received = transfer(io, *device_end, *recorded, payload);
      recorded->close();
    }
    recorder->close();
    boost::system::error_code error;
    std::string message;
    auto capture = read_capture(options.file.string(), error, message);
    ASSERT_TRUE(capture) << message;
    std::filesystem::remove_all(folder);
    std::vector<uint8_t> recorded_bytes;
    std::size_t unframed = 0;
    for (const auto& packet : capture->packets) {
      EXPECT_EQ(packet.direction, CaptureDirection::inbound);
      recorded_bytes.insert(recorded_bytes.end(), packet.data.begin(), packet.data.end());
      if (packet.unframed()) {
        ++unframed;
      } else {
        EXPECT_EQ(packet.data.front(), '#');
        EXPECT_EQ(packet.data.back(), '\n');
      }
    }
    EXPECT_EQ(recorded_bytes, received);  // every byte, in order
    EXPECT_NE(received, payload);         // the noise did hit
    EXPECT_GT(unframed, 0u);
    captures.push_back(std::move(*capture));
  }
  ASSERT_EQ(captures[0].packets.size(), captures[1].packets.size());
  for (std::size_t i = 0; i < captures[0].packets.size(); ++i) {
    EXPECT_EQ(captures[0].packets[i].data, captures[1].packets[i].data);
    EXPECT_EQ(captures[0].packets[i].comment, captures[1].packets[i].comment);
  }
}

}  // namespace
}  // namespace tether::transports
