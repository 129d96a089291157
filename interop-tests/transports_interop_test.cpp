// The echo firmware, running on the virtual Uno, reached through every host transport: the in-process
// stream, the board's pty, a real socat pty pair bridged to that pty, and a real ser2net on 127.0.0.1.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <thread>

#include "ser2net_process.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/testing/read_exactly.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using ::tether::transports::testing::read_exactly;
using tether::transports::IoThread;

const std::string kBanner = "tether echo\r\n";

VirtualUnoOptions echo_board(Pacing pacing = Pacing::real_time) {
  VirtualUnoOptions options;
  options.firmware = TETHER_ECHO_ELF;
  options.pacing = pacing;
  return options;
}

std::string random_text(std::size_t size, uint64_t stream) {
  auto generator = tether::testing::seeded_generator(stream);
  std::string text(size, '\0');
  for (auto& c : text) c = static_cast<char>(generator());
  return text;
}

// Writes `payload` in line-sized pieces while reading the echo back; the UART runs at 115200 either way.
void expect_echo(ByteStream& stream, const std::string& payload) {
  std::thread writer([&] { stream.write(asio::buffer(payload)); });
  const std::string echoed = read_exactly(stream, payload.size(), 10s);
  writer.join();
  const auto mismatch = std::mismatch(echoed.begin(), echoed.end(), payload.begin());
  EXPECT_EQ(mismatch.first, echoed.end()) << "first difference at byte " << (mismatch.first - echoed.begin());
}

TEST(EchoOverTransports, InProcessStreamGetsTheBannerThenEveryByteBack) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), echo_board(Pacing::fast));
  EXPECT_EQ(read_exactly(*stream, kBanner.size(), 10s), kBanner);
  expect_echo(*stream, random_text(3000, 1));
  EXPECT_EQ(stream->discarded(), 0u);
  stream->close();
}

TEST(EchoOverTransports, BoardPtyOpenedAsASerialPort) {
  IoThread io;
  VirtualUno board(echo_board(Pacing::fast));
  const std::string pty = board.open_pty();
  board.start();
  SerialOptions options;
  options.ready_banner = kBanner;
  auto port = SerialPortStream::open(io.executor(), pty, options);
  expect_echo(*port, random_text(2000, 2));
  port->close();
  board.stop();
}

TEST(EchoOverTransports, RealSocatPtyPairBridgedToTheBoard) {
  IoThread io;
  VirtualUno board(echo_board(Pacing::fast));
  const std::string board_pty = board.open_pty();
  board.start();
  const auto dir = std::filesystem::temp_directory_path() / ("tether-socat-uno-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string link = (dir / "uno").string();
  {
    tether::testing::ChildProcess socat({"socat", board_pty + ",raw,echo=0", "pty,raw,echo=0,link=" + link});
    ASSERT_TRUE(tether::testing::eventually([&] { return std::filesystem::exists(link); }, 5000ms));
    SerialOptions options;
    options.ready_banner = kBanner;  // the board's pty kept the boot banner for its first reader
    auto port = SerialPortStream::open(io.executor(), link, options);
    expect_echo(*port, random_text(2000, 3));
    port->close();
  }
  std::filesystem::remove_all(dir);
  board.stop();
}

TEST(EchoOverTransports, RealSer2netInFrontOfTheBoard) {
  IoThread io;
  VirtualUno board(echo_board(Pacing::fast));
  const std::string board_pty = board.open_pty();
  board.start();
  {
    test_support::Ser2netProcess ser2net(board_pty);
    ASSERT_TRUE(ser2net.wait_until_listening(5000ms));
    auto stream = TcpStream::connect(io.executor(), "127.0.0.1", ser2net.port());
    expect_echo(*stream, random_text(2000, 4));
    stream->close();
  }
  board.stop();
}

TEST(EchoOverTransports, ScheduledResetRebootsTheFirmwareAndTheStreamStaysUsable) {
  IoThread io;
  auto stream = VirtualUnoStream::open(io.executor(), echo_board(Pacing::fast));
  EXPECT_EQ(read_exactly(*stream, kBanner.size(), 10s), kBanner);
  for (const ResetKind kind : {ResetKind::watchdog, ResetKind::power_cycle}) {
    stream->board().reset(kind, 10ms);
    EXPECT_EQ(read_exactly(*stream, kBanner.size(), 10s), kBanner);  // the firmware booted again
    expect_echo(*stream, random_text(200, 5));
  }
  EXPECT_EQ(stream->board().stats().boots, 3u);
  stream->close();
}

}  // namespace
}  // namespace tether::transports
