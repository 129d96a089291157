// The ByteStream contract (deadlines, read-ahead, close, blocking calls, asio composition), exercised
// through the in-memory pair, which has no timing of its own.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <deque>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tether/testing/random_seed.hpp"
#include "tether/transports/in_memory_stream.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;

// Bytes for an asynchronous write: they must outlive the operation, so never a temporary.
const std::string& persistent(const char* text) {
  static std::deque<std::string> kept;
  return kept.emplace_back(text);
}

std::string as_string(const std::vector<uint8_t>& bytes, std::size_t size) {
  return std::string(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
}

TEST(ByteStream, BytesWrittenOnOneEndAreReadOnTheOther) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer(64);
  std::string got;
  asio::async_write(*a, asio::buffer(persistent("hello")), [](error_code error, std::size_t size) {
    EXPECT_FALSE(error);
    EXPECT_EQ(size, 5u);
  });
  asio::async_read(*b, asio::buffer(buffer, 5), [&](error_code error, std::size_t size) {
    EXPECT_FALSE(error);
    got = as_string(buffer, size);
  });
  io.run();
  EXPECT_EQ(got, "hello");
}

// Each end of a pair made with two executors completes on its own: here, each on its own io_context, run
// one after the other: the host's run completes the write and leaves the read to the device's.
TEST(ByteStream, EachEndOfAPairCanCompleteOnItsOwnExecutor) {
  asio::io_context host;
  asio::io_context device;
  auto [a, b] = InMemoryStream::make_pair(host.get_executor(), device.get_executor());
  std::vector<uint8_t> buffer(64);
  std::string got;
  bool written = false;
  asio::async_write(*a, asio::buffer(persistent("ping")), [&](error_code error, std::size_t) {
    EXPECT_FALSE(error);
    written = true;
  });
  asio::async_read(*b, asio::buffer(buffer, 4), [&](error_code error, std::size_t size) {
    EXPECT_FALSE(error);
    got = as_string(buffer, size);
  });
  host.run();
  EXPECT_TRUE(written);  // the write completed in the host's context...
  EXPECT_EQ(got, "");    // ...and the read waits for the device's
  device.run();
  EXPECT_EQ(got, "ping");
}

TEST(ByteStream, CompletionIsNeverInvokedInsideTheInitiatingCall) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  bool completed = false;
  std::vector<uint8_t> buffer(8);
  b->async_read_some(asio::buffer(buffer, 0), [&](error_code, std::size_t) { completed = true; });
  EXPECT_FALSE(completed);
  io.run();
  EXPECT_TRUE(completed);
}

TEST(ByteStream, DeadlineTimesOutAndLateBytesAreKeptForTheNextRead) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer(16);
  error_code first_error;
  std::string second;
  b->async_read_some(asio::buffer(buffer), SteadyClock::now() + 20ms, [&](error_code error, std::size_t) {
    first_error = error;
    // The peer writes only after the deadline; the next read must still get every byte.
    asio::async_write(*a, asio::buffer(persistent("late")), [](error_code, std::size_t) {});
    asio::async_read(*b, asio::buffer(buffer, 4), [&](error_code error2, std::size_t size) {
      EXPECT_FALSE(error2);
      second = as_string(buffer, size);
    });
  });
  io.run();
  EXPECT_EQ(first_error, make_error_code(TransportError::timed_out));
  EXPECT_EQ(second, "late");
}

TEST(ByteStream, AnExpiredDeadlineDoesNotTimeOutTheNextRead) {
  // Regression: a deadline whose timer had already fired when its read completed must not end a newer read.
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer(16);
  std::vector<error_code> errors;
  asio::async_write(*a, asio::buffer(persistent("x")), [](error_code, std::size_t) {});
  b->async_read_some(asio::buffer(buffer), SteadyClock::now(), [&](error_code error, std::size_t) {
    errors.push_back(error);
    b->async_read_some(asio::buffer(buffer), SteadyClock::now() + 10s, [&](error_code error2, std::size_t) {
      errors.push_back(error2);
    });
    asio::post(io, [&] { asio::async_write(*a, asio::buffer(persistent("y")), [](error_code, std::size_t) {}); });
  });
  io.run_for(2s);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_FALSE(errors[0]);
  EXPECT_FALSE(errors[1]);
}

TEST(ByteStream, BulkTransferLargerThanTheChannelLosesNothing) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor(), 64);
  auto generator = testing::seeded_generator(7);
  std::vector<uint8_t> sent(20000);
  for (auto& byte : sent) byte = static_cast<uint8_t>(generator());
  std::vector<uint8_t> received(sent.size());
  asio::async_write(*a, asio::buffer(sent), [](error_code error, std::size_t) { EXPECT_FALSE(error); });
  asio::async_read(*b, asio::buffer(received), [](error_code error, std::size_t) { EXPECT_FALSE(error); });
  io.run();
  EXPECT_EQ(received, sent);
}

TEST(ByteStream, CloseAbortsOwnReadAndPeerSeesEofAfterPendingBytes) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer_a(8);
  std::vector<uint8_t> buffer_b(8);
  error_code own_read;
  std::vector<std::pair<error_code, std::size_t>> peer_reads;
  std::function<void()> read_on = [&] {
    b->async_read_some(asio::buffer(buffer_b), [&](error_code error, std::size_t size) {
      peer_reads.emplace_back(error, size);
      if (!error) read_on();
    });
  };
  a->async_read_some(asio::buffer(buffer_a), [&](error_code error, std::size_t) { own_read = error; });
  asio::async_write(*a, asio::buffer(persistent("ab")), [&](error_code, std::size_t) {
    a->close();
    read_on();
  });
  std::thread runner([&] { io.run(); });
  runner.join();
  EXPECT_EQ(own_read, asio::error::operation_aborted);
  ASSERT_EQ(peer_reads.size(), 2u);
  EXPECT_EQ(peer_reads[0].second, 2u);
  EXPECT_EQ(peer_reads[1].first, asio::error::eof);
  EXPECT_FALSE(a->is_open());
}

TEST(ByteStream, WriteToAClosedPeerFailsWithBrokenPipe) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  error_code write_error;
  std::thread runner([&] {
    auto guard = asio::make_work_guard(io);
    io.run_for(2s);
  });
  b->close();
  asio::async_write(*a, asio::buffer(persistent("x")), [&](error_code error, std::size_t) {
    write_error = error;
    io.stop();
  });
  runner.join();
  EXPECT_EQ(write_error, asio::error::broken_pipe);
}

TEST(ByteStream, SecondConcurrentReadIsRejected) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer(8);
  error_code second;
  b->async_read_some(asio::buffer(buffer), SteadyClock::now() + 50ms, [](error_code, std::size_t) {});
  b->async_read_some(asio::buffer(buffer), [&](error_code error, std::size_t) { second = error; });
  io.run();
  EXPECT_EQ(second, make_error_code(TransportError::read_in_progress));
}

TEST(ByteStream, BlockingCallsFromAnotherThread) {
  asio::io_context io;
  auto guard = asio::make_work_guard(io);
  std::thread runner([&] { io.run(); });
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  EXPECT_EQ(a->write(asio::buffer(std::string("ping"))), 4u);
  std::vector<uint8_t> buffer(4);
  std::size_t total = 0;
  while (total < 4) total += b->read_some(asio::buffer(buffer.data() + total, 4 - total), 1s);
  EXPECT_EQ(as_string(buffer, 4), "ping");
  error_code error;
  EXPECT_EQ(b->read_some(asio::buffer(buffer), 30ms, error), 0u);
  EXPECT_EQ(error, make_error_code(TransportError::timed_out));
  EXPECT_THROW(b->read_some(asio::buffer(buffer), 10ms), boost::system::system_error);
  a->close();
  b->close();
  guard.reset();
  runner.join();
}

TEST(ByteStream, WriteWithADeadlineGivesUpOnAPeerThatNeverReads) {
  // Regression: `tether monitor` blocked for ever writing to a device that did not read.
  asio::io_context io;
  auto guard = asio::make_work_guard(io);
  std::thread runner([&] { io.run(); });
  auto [a, b] = InMemoryStream::make_pair(io.get_executor(), /*capacity=*/16);  // b never reads
  const std::string bytes(64, 'x');
  error_code error;
  const std::size_t written = a->write(asio::buffer(bytes), SteadyClock::now() + 50ms, error);
  EXPECT_EQ(error, make_error_code(TransportError::timed_out));
  EXPECT_LE(written, 16u);
  EXPECT_FALSE(a->is_open());  // the write in flight could not be taken back: the link is closed
  EXPECT_EQ(a->write(asio::buffer(bytes), SteadyClock::now() + 50ms, error), 0u);
  EXPECT_EQ(error, asio::error::operation_aborted);
  // A peer that reads gets everything before the deadline.
  auto [c, d] = InMemoryStream::make_pair(io.get_executor(), 16);
  std::thread reader([&, d = d] {
    std::vector<uint8_t> buffer(64);
    std::size_t total = 0;
    while (total < 64) total += d->read_some(asio::buffer(buffer), 10s);
  });
  EXPECT_EQ(c->write(asio::buffer(bytes), SteadyClock::now() + 30s, error), 64u);
  EXPECT_FALSE(error);
  reader.join();
  b->close();
  c->close();
  d->close();
  guard.reset();
  runner.join();
}

TEST(ByteStream, CloseWithNoThreadRunningTheExecutorDoesNotHang) {
  // Regression: close() used to wait for the strand and report would_deadlock after seconds.
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  std::vector<uint8_t> buffer(4);
  error_code read_error;
  b->async_read_some(asio::buffer(buffer), [&](error_code error, std::size_t) { read_error = error; });
  io.poll();  // the read is now waiting on the device
  error_code close_error;
  const auto started = SteadyClock::now();
  b->close(close_error);
  EXPECT_LT(SteadyClock::now() - started, 2s);
  EXPECT_FALSE(close_error);
  EXPECT_FALSE(b->is_open());
  io.run();  // when the executor runs again, the read ends
  EXPECT_EQ(read_error, asio::error::operation_aborted);
}

TEST(ByteStream, FuturesWorkAsCompletionTokens) {
  asio::io_context io;
  auto guard = asio::make_work_guard(io);
  std::thread runner([&] { io.run(); });
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  auto written = asio::async_write(*a, asio::buffer(persistent("fut")), asio::use_future);
  std::vector<uint8_t> buffer(3);
  auto read = asio::async_read(*b, asio::buffer(buffer), asio::use_future);
  EXPECT_EQ(written.get(), 3u);
  EXPECT_EQ(read.get(), 3u);
  EXPECT_EQ(as_string(buffer, 3), "fut");
  guard.reset();
  runner.join();
}

TEST(ByteStream, BlockingReadOnTheStreamsOwnStrandIsRefused) {
  asio::io_context io;
  auto [a, b] = InMemoryStream::make_pair(io.get_executor());
  error_code error;
  std::vector<uint8_t> buffer(1);
  // A completion handler of b runs on b's strand: a blocking read there could never complete.
  b->async_read_some(asio::buffer(buffer, 0), [&](error_code, std::size_t) {
    b->read_some(asio::buffer(buffer), 1s, error);
  });
  io.run();
  EXPECT_EQ(error, make_error_code(TransportError::would_deadlock));
}

TEST(TransportError, HasMessages) {
  EXPECT_EQ(make_error_code(TransportError::timed_out).message(), "operation timed out");
  EXPECT_STREQ(make_error_code(TransportError::closed).category().name(), "tether.transport");
}

}  // namespace
}  // namespace tether::transports

namespace tether::transports {
namespace {

TEST(ByteStream, DroppedStreamWithAReadAheadPendingIsFreed) {
  // Regression: the internal device read held the stream, and an in-memory channel held that read, so a
  // stream dropped after a timed-out read was never freed (LeakSanitizer found it).
  asio::io_context io;
  std::weak_ptr<InMemoryStream> weak_a;
  std::weak_ptr<InMemoryStream> weak_b;
  {
    auto [a, b] = InMemoryStream::make_pair(io.get_executor());
    weak_a = a;
    weak_b = b;
    std::vector<uint8_t> buffer(4);
    b->async_read_some(asio::buffer(buffer), SteadyClock::now() + 5ms, [](error_code, std::size_t) {});
    io.run_for(50ms);  // the read timed out; the device read stays parked in the channel
  }
  io.poll();
  EXPECT_TRUE(weak_a.expired());
  EXPECT_TRUE(weak_b.expired());
}

TEST(ByteStream, DestroyingAStreamCompletesItsPendingReadWithOperationAborted) {
  asio::io_context io;
  error_code error;
  bool called = false;
  std::vector<uint8_t> buffer(4);
  {
    auto [a, b] = InMemoryStream::make_pair(io.get_executor());
    b->async_read_some(asio::buffer(buffer), [&](error_code e, std::size_t) {
      called = true;
      error = e;
    });
    io.poll();  // the read is pending now
  }
  io.run_for(1s);
  EXPECT_TRUE(called);
  EXPECT_EQ(error, asio::error::operation_aborted);
}

}  // namespace
}  // namespace tether::transports
