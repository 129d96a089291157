// Serial port, pty and TCP streams against real OS objects: ptys, a socat pty pair, loopback TCP.
#include <gtest/gtest.h>

#include <sys/ioctl.h>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <atomic>
#include <cctype>
#include <filesystem>
#include <future>
#include <random>
#include <string>
#include <thread>

#include "tether/testing/child_process.hpp"
#include "tether/transports/io_thread.hpp"
#include "ser2net_process.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/testing/read_exactly.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using ::tether::transports::testing::read_exactly;

using IoThread = tether::transports::IoThread;

TEST(PtyStream, SerialPortOnTheSlaveTalksToTheMaster) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  auto port = SerialPortStream::open(io.executor(), pty->slave_path());
  pty->write(asio::buffer(std::string("to port\r\n")));
  EXPECT_EQ(read_exactly(*port, 9, 5s), "to port\r\n");  // raw: no CR/LF translation, no echo
  port->write(asio::buffer(std::string("to pty")));
  EXPECT_EQ(read_exactly(*pty, 6, 5s), "to pty");
  EXPECT_NE(port->description().find(pty->slave_path()), std::string::npos);
  port->close();
  pty->close();
}

TEST(SerialPortStream, MissingDeviceIsAClearError) {
  IoThread io;
  error_code error;
  auto port = SerialPortStream::open(io.executor(), "/dev/tether-no-such-port", SerialOptions(), error);
  EXPECT_EQ(port, nullptr);
  EXPECT_EQ(error, boost::system::errc::no_such_file_or_directory);
  EXPECT_THROW(SerialPortStream::open(io.executor(), "/dev/tether-no-such-port"), boost::system::system_error);
}

TEST(SerialPortStream, NonStandardBaudIsRejectedAsInvalidOption) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  SerialOptions options;
  options.baud = 74801;
  error_code error;
  EXPECT_EQ(SerialPortStream::open(io.executor(), pty->slave_path(), options, error), nullptr);
  EXPECT_EQ(error, make_error_code(TransportError::invalid_option));
  pty->close();
}

TEST(SerialPortStream, ExclusiveAccessIsRequested) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  auto port = SerialPortStream::open(io.executor(), pty->slave_path());
  int exclusive = 0;
  ASSERT_EQ(::ioctl(port->object().native_handle(), TIOCGEXCL, &exclusive), 0);
  EXPECT_EQ(exclusive, 1);
  if (::geteuid() != 0) {  // root may open an exclusive tty anyway; everyone else must be refused
    error_code error;
    EXPECT_EQ(SerialPortStream::open(io.executor(), pty->slave_path(), SerialOptions(), error), nullptr);
    EXPECT_EQ(error, boost::system::errc::device_or_resource_busy);
  }
  port->close();
  pty->close();
}

TEST(SerialPortStream, WaitsForTheReadyBannerAndKeepsWhatFollows) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  SerialOptions options;
  options.ready_banner = "tether echo\r\n";
  auto opened = std::make_shared<std::promise<std::shared_ptr<SerialPortStream>>>();  // outlives a failed wait
  SerialPortStream::async_open(io.executor(), pty->slave_path(), options,
                               [opened](error_code, std::shared_ptr<SerialPortStream> port) { opened->set_value(port); });
  // The device boots after the open started (no wait for it: the bytes stay in the pty until read).
  pty->write(asio::buffer(std::string("\x00\xff boot noise\r\ntether echo\r\nfirst", 33)));
  auto future = opened->get_future();
  ASSERT_EQ(future.wait_for(5s), std::future_status::ready);
  auto port = future.get();
  ASSERT_NE(port, nullptr);
  EXPECT_EQ(read_exactly(*port, 5, 5s), "first");
  port->close();
  pty->close();
}

TEST(SerialPortStream, MissingBannerIsABootTimeout) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  SerialOptions options;
  options.ready_banner = "never";
  options.boot_timeout = 100ms;
  error_code error;
  EXPECT_EQ(SerialPortStream::open(io.executor(), pty->slave_path(), options, error), nullptr);
  EXPECT_EQ(error, make_error_code(TransportError::boot_timeout));
  pty->close();
}

TEST(SerialPortStream, BootNoiseBeforeTheWaitEndsIsDiscarded) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  pty->write(asio::buffer(std::string("bootloader garbage")));
  SerialOptions options;
  options.boot_wait = 50ms;
  auto port = SerialPortStream::open(io.executor(), pty->slave_path(), options);
  pty->write(asio::buffer(std::string("app")));
  EXPECT_EQ(read_exactly(*port, 3, 5s), "app");
  port->close();
  pty->close();
}

TEST(SerialPortStream, VanishedDeviceEndsAPendingReadWithAnError) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  auto port = SerialPortStream::open(io.executor(), pty->slave_path());
  std::vector<uint8_t> buffer(8);
  auto ended = std::make_shared<std::promise<error_code>>();  // outlives a failed wait
  port->async_read_some(asio::buffer(buffer), std::chrono::steady_clock::now() + 5s,
                        [ended](error_code e, std::size_t) { ended->set_value(e); });
  pty->close();  // once the read is started: the other end of the line disappears (a USB adapter unplugged)
  auto future = ended->get_future();
  ASSERT_EQ(future.wait_for(10s), std::future_status::ready);
  const error_code error = future.get();
  EXPECT_TRUE(error);
  EXPECT_NE(error, make_error_code(TransportError::timed_out)) << error.message();
  port->close();
}

TEST(SocatPtyPair, BulkDataCrossesARealSocatPair) {
  IoThread io;
  const auto dir = std::filesystem::temp_directory_path() / ("tether-socat-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto a_path = (dir / "a").string();
  const auto b_path = (dir / "b").string();
  {
    ::tether::testing::ChildProcess socat({"socat", "pty,raw,echo=0,link=" + a_path, "pty,raw,echo=0,link=" + b_path});
    ASSERT_TRUE(::tether::testing::eventually(
        [&] { return std::filesystem::exists(a_path) && std::filesystem::exists(b_path); }, 5000ms));
    auto a = SerialPortStream::open(io.executor(), a_path);
    auto b = SerialPortStream::open(io.executor(), b_path);
    auto generator = ::tether::testing::seeded_generator(11);
    std::string payload(4000, '\0');
    for (auto& c : payload) c = static_cast<char>(generator());
    std::thread writer([&] { a->write(asio::buffer(payload)); });
    const std::string received = read_exactly(*b, payload.size(), 5s);
    writer.join();
    EXPECT_EQ(received, payload);
    a->close();
    b->close();
  }
  std::filesystem::remove_all(dir);
}

TEST(TcpStream, RoundTripOnLoopback) {
  IoThread io;
  asio::io_context server_io;
  asio::ip::tcp::acceptor acceptor(server_io, {asio::ip::make_address("127.0.0.1"), 0});
  const unsigned short port = acceptor.local_endpoint().port();
  std::thread server([&] {
    asio::ip::tcp::socket peer(server_io);
    acceptor.accept(peer);
    char buffer[5];
    asio::read(peer, asio::buffer(buffer));
    asio::write(peer, asio::buffer(buffer));  // echo
  });
  auto stream = TcpStream::connect(io.executor(), "127.0.0.1", port);
  stream->write(asio::buffer(std::string("hello")));
  EXPECT_EQ(read_exactly(*stream, 5, 5s), "hello");
  server.join();
  stream->close();
}

TEST(TcpStream, RefusedConnectionIsAnError) {
  IoThread io;
  unsigned short port = 0;
  {
    asio::io_context probe;
    asio::ip::tcp::acceptor acceptor(probe, {asio::ip::make_address("127.0.0.1"), 0});
    port = acceptor.local_endpoint().port();
  }  // closed again: nobody listens there now
  error_code error;
  EXPECT_EQ(TcpStream::connect(io.executor(), "127.0.0.1", port, 2000ms, error), nullptr);
  EXPECT_EQ(error, asio::error::connection_refused);
}

TEST(TcpStream, PeerClosingEndsAPendingReadWithEof) {
  IoThread io;
  asio::io_context server_io;
  asio::ip::tcp::acceptor acceptor(server_io, {asio::ip::make_address("127.0.0.1"), 0});
  std::promise<void> reading;
  std::thread server([&] {
    asio::ip::tcp::socket peer(server_io);
    acceptor.accept(peer);
    reading.get_future().wait_for(5s);  // the client's read is started
  });  // peer closes when the thread ends
  auto stream = TcpStream::connect(io.executor(), "127.0.0.1", acceptor.local_endpoint().port());
  std::vector<uint8_t> buffer(4);
  auto ended = std::make_shared<std::promise<error_code>>();  // outlives a failed wait
  stream->async_read_some(asio::buffer(buffer), std::chrono::steady_clock::now() + 5s,
                          [ended](error_code e, std::size_t) { ended->set_value(e); });
  reading.set_value();
  auto future = ended->get_future();
  ASSERT_EQ(future.wait_for(10s), std::future_status::ready);
  server.join();
  EXPECT_EQ(future.get(), asio::error::eof);
  stream->close();
}

}  // namespace
}  // namespace tether::transports

namespace tether::transports {
namespace {

TEST(Ser2net, TcpClientReachesAPtyDeviceThroughARealSer2net) {
  IoThread io;
  auto device = PtyStream::open(io.executor());
  // The device echoes in upper case, so the test sees that the bytes went through it.
  std::atomic<bool> running{true};
  std::thread echo([&] {
    std::vector<uint8_t> buffer(256);
    while (running) {
      error_code error;
      const std::size_t got = device->read_some(asio::buffer(buffer), 50ms, error);
      for (std::size_t i = 0; i < got; ++i) buffer[i] = static_cast<uint8_t>(std::toupper(buffer[i]));
      if (got > 0) device->write(asio::buffer(buffer.data(), got));
    }
  });
  {
    test_support::Ser2netProcess ser2net(device->slave_path());
    ASSERT_TRUE(ser2net.wait_until_listening(5000ms));
    auto stream = TcpStream::connect(io.executor(), "127.0.0.1", ser2net.port());
    stream->write(asio::buffer(std::string("through ser2net")));
    EXPECT_EQ(read_exactly(*stream, 15, 5s), "THROUGH SER2NET");
    stream->close();
  }
  running = false;
  echo.join();
  device->close();
}

}  // namespace
}  // namespace tether::transports
