// Serial port, pty and TCP streams against real OS objects: ptys, a socat pty pair, loopback TCP.
#include <gtest/gtest.h>

#include <sys/ioctl.h>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <optional>
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
#include "tether/transports/testing/fake_port_tree.hpp"
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

TEST(SerialPortStream, VanishedDeviceEndsAPendingReadWithAnErrorWithoutReconnect) {
  IoThread io;
  auto pty = PtyStream::open(io.executor());
  SerialOptions options;
  options.reconnect.enabled = false;
  auto port = SerialPortStream::open(io.executor(), pty->slave_path(), options);
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
  EXPECT_NE(error, make_error_code(TransportError::disconnected)) << error.message();
  port->close();
}

// Link events, for waiting on them.
class LinkEvents {
 public:
  void add(const LinkEvent& event) {
    std::lock_guard lock(mutex_);
    events_.push_back(event);
    changed_.notify_all();
  }
  std::optional<LinkEvent> wait(std::size_t n) {
    std::unique_lock lock(mutex_);
    if (!changed_.wait_for(lock, 20s, [&] { return events_.size() >= n; })) return std::nullopt;
    return events_[n - 1];
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<LinkEvent> events_;
};

// One read's outcome (the completion may come after a failed wait: shared).
std::pair<error_code, std::string> read_once(ByteStream& stream) {
  auto buffer = std::make_shared<std::array<char, 64>>();
  auto done = std::make_shared<std::promise<std::pair<error_code, std::string>>>();
  stream.async_read_some(asio::buffer(*buffer), std::chrono::steady_clock::now() + 20s,
                         [buffer, done](error_code e, std::size_t n) { done->set_value({e, std::string(buffer->data(), n)}); });
  auto future = done->get_future();
  if (future.wait_for(30s) != std::future_status::ready) return {make_error_code(TransportError::timed_out), ""};
  return future.get();
}

// A port named by its by-id name: the pty behind it goes away and a new one (another /dev/pts/N) takes the
// name. The reader sees `disconnected`, then `reconnected`, then the new connection's bytes; writes during
// the outage fail `disconnected` at once; the counters and events tell the story.
TEST(SerialPortStream, ReopensAPortThatComesBackUnderAnotherPath) {
  IoThread io;
  testing::FakePortTree tree;
  const testing::UsingFakePortTree use(tree);
  auto first = PtyStream::open(io.executor());
  tree.add_by_id("usb-board-if00", first->slave_path());
  PortSpec spec;
  spec.by_id = "usb-board-if00";
  auto opened = SerialPortStream::async_open(io.executor(), spec, SerialOptions(), asio::use_future);
  auto port = opened.get();
  LinkEvents events;
  port->add_link_handler([&events](const LinkEvent& event) { events.add(event); });
  first->write(asio::buffer(std::string("before")));
  EXPECT_EQ(read_exactly(*port, 6, 5s), "before");

  auto second = PtyStream::open(io.executor());  // while the first is open: it gets another number
  EXPECT_NE(second->slave_path(), first->slave_path());
  tree.remove_by_id("usb-board-if00");
  first->close();  // unplugged
  EXPECT_EQ(read_once(*port).first, make_error_code(TransportError::disconnected));
  const auto down = events.wait(1);
  ASSERT_TRUE(down);
  EXPECT_EQ(down->kind, LinkEvent::Kind::down);
  EXPECT_EQ(down->path, first->slave_path());
  error_code write_error;
  port->write(asio::buffer(std::string("lost")), write_error);
  EXPECT_EQ(write_error, make_error_code(TransportError::disconnected));
  EXPECT_FALSE(port->link_counters().up);

  tree.add_by_id("usb-board-if00", second->slave_path());
  const auto back = read_once(*port);
  EXPECT_EQ(back.first, make_error_code(TransportError::reconnected));
  EXPECT_EQ(back.second, "");
  const auto up = events.wait(2);
  ASSERT_TRUE(up);
  EXPECT_EQ(up->kind, LinkEvent::Kind::up);
  EXPECT_EQ(up->path, second->slave_path());
  EXPECT_EQ(port->path(), second->slave_path());
  second->write(asio::buffer(std::string("after")));
  EXPECT_EQ(read_exactly(*port, 5, 5s), "after");
  port->write(asio::buffer(std::string("to new")));
  EXPECT_EQ(read_exactly(*second, 6, 5s), "to new");
  const LinkCounters counters = port->link_counters();
  EXPECT_EQ(counters.disconnects, 1u);
  EXPECT_EQ(counters.reconnects, 1u);
  EXPECT_TRUE(counters.up);
  EXPECT_FALSE(counters.gave_up);
  EXPECT_GE(counters.time_down, up->down_for);
  port->close();
  second->close();
}

// With an attempt limit, a port that does not come back ends the stream: `gave_up`, then reads and writes
// fail `reconnect_limit`. The backoff is bounded below by first_delay: three attempts take >= 10+20+40 ms.
TEST(SerialPortStream, GivesUpAfterItsAttemptLimit) {
  IoThread io;
  testing::FakePortTree tree;  // by-id, so that no other pty taking the number can answer
  const testing::UsingFakePortTree use(tree);
  auto pty = PtyStream::open(io.executor());
  tree.add_by_id("usb-board-if00", pty->slave_path());
  PortSpec spec;
  spec.by_id = "usb-board-if00";
  SerialOptions options;
  options.reconnect.first_delay = std::chrono::milliseconds(10);
  options.reconnect.max_attempts = 3;
  auto port = SerialPortStream::async_open(io.executor(), spec, options, asio::use_future).get();
  LinkEvents events;
  port->add_link_handler([&events](const LinkEvent& event) { events.add(event); });
  tree.remove_by_id("usb-board-if00");
  pty->close();
  EXPECT_EQ(read_once(*port).first, make_error_code(TransportError::disconnected));
  const auto gave_up = events.wait(2);
  ASSERT_TRUE(gave_up);
  EXPECT_EQ(gave_up->kind, LinkEvent::Kind::gave_up);
  EXPECT_EQ(gave_up->attempts, 3u);
  EXPECT_GE(gave_up->down_for, std::chrono::milliseconds(70));
  EXPECT_EQ(read_once(*port).first, make_error_code(TransportError::reconnect_limit));
  error_code write_error;
  port->write(asio::buffer(std::string("x")), write_error);
  EXPECT_EQ(write_error, make_error_code(TransportError::reconnect_limit));
  EXPECT_TRUE(port->link_counters().gave_up);
  EXPECT_EQ(port->link_counters().reconnects, 0u);
  EXPECT_EQ(gave_up->reason, "no serial port matches by-id usb-board-if00 (no serial ports found)");
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
