// ClientLink: the read loop, write queue, timer, link failure and close shared by the codec clients,
// exercised over the in-memory pair with a minimal derived client that records its hooks.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tether/client/client_link.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/in_memory_stream.hpp"

namespace tether::client {
namespace {

using transports::ByteStream;
using transports::InMemoryStream;
using transports::TransportError;
using transports::UniqueFunction;

using namespace std::chrono_literals;

// A client with no protocol: records what the link reports and exposes the protected interface.
class RecordingLink final : public ClientLink {
 public:
  explicit RecordingLink(std::shared_ptr<ByteStream> stream, std::shared_ptr<LinkClock> clock = nullptr)
      : ClientLink(std::move(stream), std::move(clock)) {}

  void start() {
    post_to_strand([this] { start_reading(); });
  }
  void send(std::string text, WriteDone done = {}) {
    auto shared = std::make_shared<const std::string>(std::move(text));
    post_to_strand([this, shared, done = std::move(done)]() mutable { write(shared, std::move(done)); });
  }
  void arm_in(std::int32_t milliseconds) {
    post_to_strand([this, milliseconds] {
      Deadline wakeup;
      wakeup.arm_at(static_cast<Millis>(now() + static_cast<Millis>(milliseconds)));
      arm_timer(wakeup);
    });
  }
  void disarm() {
    post_to_strand([this] { arm_timer(Deadline()); });
  }
  void cancel() {
    post_to_strand([this] { cancel_timer(); });
  }

  std::string bytes;
  int timer_fired = 0;
  int link_failures = 0;
  error_code failure;
  int restored = 0;
  bool down_when_restored = true;  // link_down() as on_link_restored saw it
  int closes = 0;
  std::function<void()> on_bytes_hook;

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    bytes.append(reinterpret_cast<const char*>(data), size);
    if (on_bytes_hook) on_bytes_hook();
  }
  void on_timer() override { ++timer_fired; }
  void on_link_failed(const error_code& error) override {
    ++link_failures;
    failure = error;
  }
  void on_link_restored() override {
    ++restored;
    down_when_restored = link_down() || link_error();
  }
  void on_closed() override { ++closes; }
};

// A stream whose reads the test completes (bytes, or a supervised port's notices: `disconnected`,
// `reconnected`, a final error), and whose writes fail with `disconnected` while `down` is set: what a
// SerialPortStream does around an outage, without a port.
class ScriptedStream final : public ByteStream {
 public:
  explicit ScriptedStream(executor_type executor) : ByteStream(std::move(executor)) {}
  std::string description() const override { return "scripted"; }

  // The next read completes with `error`, or with `bytes`. Any thread.
  void deliver(error_code error, std::string bytes = {}) {
    asio::post(strand(), [self = self(), error, bytes = std::move(bytes)] {
      self->script_.push_back({error, bytes});
      self->serve();
    });
  }
  bool down = false;    // strand (the test runs the io_context itself: one thread)
  std::string written;  // strand

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override {
    buffer_ = buffer;
    read_ = std::move(handler);
    asio::post(strand(), [self = self()] { self->serve(); });
  }
  void do_write(asio::const_buffer buffer, IoHandler handler) override {
    asio::post(strand(), [self = self(), buffer, handler = std::move(handler)]() mutable {
      if (self->down) {
        handler(make_error_code(TransportError::disconnected), 0);
        return;
      }
      self->written.append(static_cast<const char*>(buffer.data()), buffer.size());
      handler(error_code(), buffer.size());
    });
  }
  void do_close(error_code& error) override {
    error.clear();
    script_.clear();
    if (read_) asio::post(strand(), [handler = std::move(read_)]() mutable { handler(asio::error::operation_aborted, 0); });
    read_ = IoHandler();
  }

 private:
  struct Step {
    error_code error;
    std::string bytes;
  };
  std::shared_ptr<ScriptedStream> self() { return std::static_pointer_cast<ScriptedStream>(shared_from_this()); }
  void serve() {
    if (!read_ || script_.empty()) return;
    const Step step = script_.front();
    script_.erase(script_.begin());
    IoHandler handler = std::move(read_);
    read_ = IoHandler();
    const std::size_t size = std::min(step.bytes.size(), buffer_.size());
    std::memcpy(buffer_.data(), step.bytes.data(), size);
    handler(step.error, step.error ? 0 : size);
  }

  asio::mutable_buffer buffer_;
  IoHandler read_;
  std::vector<Step> script_;
};

// Runs `io` until `done()` holds or `timeout` passed; the result of `done()`. Positive waits use the 10 s
// default, a bound only against hangs: load delays a steady timer, it never makes one fire early.
bool run_until(asio::io_context& io, const std::function<bool()>& done, std::chrono::milliseconds timeout = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done() && std::chrono::steady_clock::now() < deadline) {
    io.restart();
    io.run_for(5ms);
  }
  return done();
}

// Keeps reading `end` into `into` (the peer's side).
void drain(const std::shared_ptr<ByteStream>& end, std::shared_ptr<std::string> into) {
  auto buffer = std::make_shared<std::array<char, 64>>();
  end->async_read_some(asio::buffer(*buffer), [end, into, buffer](error_code error, std::size_t size) {
    if (error) return;
    into->append(buffer->data(), size);
    drain(end, into);
  });
}

TEST(ClientLink, DeliversEveryByteReadInOrder) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  link->start();
  static const std::string kFirst = "abc";
  static const std::string kSecond = "defgh";
  asio::async_write(*far, asio::buffer(kFirst), [](error_code, std::size_t) {});
  ASSERT_TRUE(run_until(io, [&] { return link->bytes.size() == 3; }));
  asio::async_write(*far, asio::buffer(kSecond), [](error_code, std::size_t) {});
  ASSERT_TRUE(run_until(io, [&] { return link->bytes.size() == 8; }));
  EXPECT_EQ(link->bytes, "abcdefgh");
  link->close();
}

TEST(ClientLink, WritesLeaveInQueueOrderAndReportEach) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor(), 4);  // small: writes wait for the reader
  auto link = std::make_shared<RecordingLink>(near);
  link->start();
  std::vector<int> done;
  for (int i = 0; i < 3; ++i) {
    link->send("frame" + std::to_string(i) + ";", [&done, i](error_code error) {
      EXPECT_FALSE(error);
      done.push_back(i);
    });
  }
  auto got = std::make_shared<std::string>();
  drain(far, got);
  ASSERT_TRUE(run_until(io, [&] { return done.size() == 3; }));
  EXPECT_EQ(*got, "frame0;frame1;frame2;");
  EXPECT_EQ(done, (std::vector<int>{0, 1, 2}));
  link->close();
  far->close();
  io.restart();
  io.run();
}

TEST(ClientLink, TimerFiresAtTheDeadlineOnce) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  const auto started = std::chrono::steady_clock::now();
  link->arm_in(30);
  ASSERT_TRUE(run_until(io, [&] { return link->timer_fired == 1; }));
  EXPECT_GE(std::chrono::steady_clock::now() - started, 25ms);
  EXPECT_FALSE(run_until(io, [&] { return link->timer_fired > 1; }, 100ms));
  link->close();
}

TEST(ClientLink, ADeadlineInThePastFiresAtOnce) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  link->arm_in(-5000);
  EXPECT_TRUE(run_until(io, [&] { return link->timer_fired == 1; }));
  link->close();
}

TEST(ClientLink, ReArmingMovesTheDeadline) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  link->arm_in(10000);
  link->arm_in(20);  // earlier
  ASSERT_TRUE(run_until(io, [&] { return link->timer_fired == 1; }));
  link->arm_in(20);
  link->arm_in(10000);  // later: the first wait is replaced
  EXPECT_FALSE(run_until(io, [&] { return link->timer_fired > 1; }, 200ms));
  link->close();
}

TEST(ClientLink, CancelledOrDisarmedTimerDoesNotFire) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  link->arm_in(20);
  link->cancel();
  EXPECT_FALSE(run_until(io, [&] { return link->timer_fired > 0; }, 150ms));
  link->arm_in(20);
  link->disarm();
  EXPECT_FALSE(run_until(io, [&] { return link->timer_fired > 0; }, 150ms));
  link->arm_in(20);  // armed again after a cancel
  EXPECT_TRUE(run_until(io, [&] { return link->timer_fired == 1; }));
  link->close();
}

TEST(ClientLink, LinkFailureIsReportedOnceAndStopsTheLink) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  link->start();
  link->arm_in(100);
  far->close();  // EOF for the reader, broken pipe for the writer
  ASSERT_TRUE(run_until(io, [&] { return link->link_failures == 1; }));
  EXPECT_TRUE(link->failure);
  std::vector<error_code> results;
  link->send("late", [&](error_code error) { results.push_back(error); });
  link->send("later", [&](error_code error) { results.push_back(error); });
  ASSERT_TRUE(run_until(io, [&] { return results.size() == 2; }));
  EXPECT_EQ(results[0], asio::error::operation_aborted);
  EXPECT_EQ(results[1], asio::error::operation_aborted);
  EXPECT_FALSE(run_until(io, [&] { return link->timer_fired > 0 || link->link_failures > 1; }, 250ms));
  EXPECT_TRUE(link->is_open());  // failed, not closed
  link->close();
  EXPECT_TRUE(run_until(io, [&] { return link->closes == 1; }));
  EXPECT_EQ(link->link_failures, 1);
}

// A supervised port's outage is a notice, not the end: the hook runs once with `disconnected` (the timer
// cancelled, queued writes dropped), reading goes on, and when the stream says the port is back the link
// error is cleared, on_link_restored runs and writes and reads flow again. A final error after that (the
// reconnect limit) ends the link for good. Simulated time only: the timer's deadline passes during the
// outage on the manual clock and nothing fires.
TEST(ClientLink, AnOutageIsANoticeAndTheLinkGoesOnWhenThePortIsBack) {
  asio::io_context io;
  auto stream = std::make_shared<ScriptedStream>(io.get_executor());
  auto clock = testing::ManualClock::create();
  auto link = std::make_shared<RecordingLink>(stream, clock);
  link->start();
  stream->deliver(error_code(), "a");
  ASSERT_TRUE(run_until(io, [&] { return link->bytes == "a"; }));
  stream->deliver(make_error_code(TransportError::reconnected));  // not down: nothing to restore
  stream->deliver(error_code(), "b");
  ASSERT_TRUE(run_until(io, [&] { return link->bytes == "ab"; }));
  EXPECT_EQ(link->restored, 0);

  link->arm_in(100);
  ASSERT_TRUE(run_until(io, [&] { return clock->pending() == 1; }));
  stream->down = true;
  stream->deliver(make_error_code(TransportError::disconnected));
  ASSERT_TRUE(run_until(io, [&] { return link->link_failures == 1; }));
  EXPECT_EQ(link->failure, make_error_code(TransportError::disconnected));
  std::vector<error_code> results;
  link->send("lost", [&](error_code error) { results.push_back(error); });
  ASSERT_TRUE(run_until(io, [&] { return results.size() == 1; }));
  EXPECT_EQ(results[0], asio::error::operation_aborted);
  stream->deliver(make_error_code(TransportError::disconnected));  // a second notice of the same outage
  clock->advance(1000);
  io.restart();
  io.poll();
  EXPECT_EQ(link->link_failures, 1);
  EXPECT_EQ(link->timer_fired, 0);

  stream->down = false;
  stream->deliver(make_error_code(TransportError::reconnected));
  ASSERT_TRUE(run_until(io, [&] { return link->restored == 1; }));
  EXPECT_FALSE(link->down_when_restored);
  link->send("back", [&](error_code error) { results.push_back(error); });
  stream->deliver(error_code(), "c");
  ASSERT_TRUE(run_until(io, [&] { return results.size() == 2 && link->bytes == "abc"; }));
  EXPECT_FALSE(results[1]);
  EXPECT_EQ(stream->written, "back");
  link->arm_in(100);
  ASSERT_TRUE(run_until(io, [&] { return clock->pending() == 1; }));
  clock->advance(100);
  ASSERT_TRUE(run_until(io, [&] { return link->timer_fired == 1; }));

  // Another outage that ends for good: the hook runs again with the final error, and reading stops.
  stream->deliver(make_error_code(TransportError::disconnected));
  stream->deliver(make_error_code(TransportError::reconnect_limit));
  ASSERT_TRUE(run_until(io, [&] { return link->link_failures == 3; }));
  EXPECT_EQ(link->failure, make_error_code(TransportError::reconnect_limit));
  stream->deliver(error_code(), "d");
  stream->deliver(make_error_code(TransportError::reconnected));
  EXPECT_FALSE(run_until(io, [&] { return link->bytes != "abc" || link->restored != 1; }, 100ms));
  link->close();
  EXPECT_TRUE(run_until(io, [&] { return link->closes == 1; }));
}

TEST(ClientLink, AWriteErrorIsALinkFailure) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);  // not reading: only the write sees the failure
  far->close();
  error_code written;
  bool reported = false;
  link->send("bytes", [&](error_code error) {
    written = error;
    reported = true;
  });
  ASSERT_TRUE(run_until(io, [&] { return reported && link->link_failures == 1; }));
  EXPECT_TRUE(written);
  EXPECT_EQ(link->failure, written);
  link->close();
}

TEST(ClientLink, CloseAbortsQueuedWritesAndNeverHangs) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor(), 2);  // nobody reads: the first write waits
  auto link = std::make_shared<RecordingLink>(near);
  link->start();
  link->arm_in(60000);
  std::vector<error_code> results;
  for (int i = 0; i < 3; ++i) link->send("0123456789", [&](error_code error) { results.push_back(error); });
  io.restart();
  io.poll();
  link->close();
  link->close();  // idempotent
  EXPECT_FALSE(link->is_open());
  io.restart();
  io.run();  // returns: read, writes and timer all end
  EXPECT_EQ(link->closes, 1);
  EXPECT_EQ(link->link_failures, 0);
  EXPECT_EQ(link->timer_fired, 0);
  ASSERT_EQ(results.size(), 3u);
  for (const error_code& error : results) EXPECT_TRUE(error);
  bool late = false;
  link->send("after", [&](error_code error) { late = error == asio::error::operation_aborted; });
  io.restart();
  io.run();
  EXPECT_TRUE(late);
}

TEST(ClientLink, CloseFromAHookIsDeferred) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  int closes_seen_in_hook = -1;
  link->on_bytes_hook = [&] {
    link->close();
    closes_seen_in_hook = link->closes;
  };
  link->start();
  static const std::string kBytes = "x";
  asio::async_write(*far, asio::buffer(kBytes), [](error_code, std::size_t) {});
  ASSERT_TRUE(run_until(io, [&] { return link->closes == 1; }));
  EXPECT_EQ(closes_seen_in_hook, 0);
  link->on_bytes_hook = nullptr;
}

TEST(ClientLink, DroppingTheLastReferenceFreesTheLink) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  std::weak_ptr<RecordingLink> weak;
  {
    auto link = std::make_shared<RecordingLink>(near);
    weak = link;
    link->start();
    io.poll();  // the read is pending, holding the link weakly
  }
  near.reset();
  EXPECT_TRUE(weak.expired());
  io.restart();
  io.run();  // the aborted read finds no link
  EXPECT_TRUE(weak.expired());
}

TEST(ClientLink, ClosedLinkIsFreedOnceTheIoContextRan) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  std::weak_ptr<RecordingLink> weak;
  {
    auto link = std::make_shared<RecordingLink>(near);
    weak = link;
    link->start();
    link->arm_in(60000);
    link->send("bytes");
    link->close();
  }
  near.reset();
  io.run();
  EXPECT_TRUE(weak.expired());
}

// A clock whose timers keep the pending wait's handler (ManualClock, VirtualUnoClock) and an io_context
// that stops before the close's posted work ran (IoThread's destructor): the link must still be freed. It
// was not while the timer's handler held the link strongly (link -> clock -> wait -> handler -> link):
// LeakSanitizer failed interop.ProxyInterop.AnMcuResetIsDetected... after it passed, now and then.
TEST(ClientLink, APendingWaitKeptByItsClockDoesNotKeepTheLinkAlive) {
  std::weak_ptr<RecordingLink> weak;
  {
    asio::io_context io;
    auto [near, far] = InMemoryStream::make_pair(io.get_executor());
    auto clock = testing::ManualClock::create();
    {
      auto link = std::make_shared<RecordingLink>(near, clock);
      weak = link;
      link->start();
      link->arm_in(60000);
      io.poll();  // the wait is pending, its handler held by the clock
      ASSERT_EQ(clock->pending(), 1u);
      link->close();  // its cancel_timer is posted, never run: the io_context is destroyed first
    }
    near.reset();
    far.reset();
  }
  EXPECT_TRUE(weak.expired());
}

TEST(ClientLink, CompletionsArePostedNeverRunInline) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  bool inside = false;
  bool ran = false;
  std::string got;
  link->post_to_strand([&] {
    inside = true;
    link->post_completion(
        [&](int number, std::string text) {
          ran = true;
          EXPECT_FALSE(inside);
          EXPECT_FALSE(link->on_strand());
          got = std::to_string(number) + text;
        },
        7, std::string("x"));
    inside = false;
  });
  io.run();
  EXPECT_TRUE(ran);
  EXPECT_EQ(got, "7x");
  link->close();
}

TEST(ClientLink, WaitingOnTheStrandWouldDeadlock) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  bool started = false;
  error_code error;
  int result = 0;
  link->post_to_strand([&] {
    EXPECT_FALSE(wait_for_completion(*link, [&](UniqueFunction<void(error_code, int)>) { started = true; }, error,
                                     result));
  });
  io.run();
  EXPECT_FALSE(started);
  EXPECT_EQ(error, make_error_code(TransportError::would_deadlock));
  link->close();
}

TEST(ClientLink, WaitForCompletionReturnsTheResult) {
  asio::io_context io;
  auto [near, far] = InMemoryStream::make_pair(io.get_executor());
  auto link = std::make_shared<RecordingLink>(near);
  auto work = asio::make_work_guard(io);
  std::thread runner([&] { io.run(); });
  error_code error;
  std::string result;
  const bool waited = wait_for_completion(
      *link,
      [&](UniqueFunction<void(error_code, std::string)> handler) {
        link->post_completion(std::move(handler), error_code(asio::error::timed_out), std::string("done"));
      },
      error, result);
  work.reset();
  link->close();
  runner.join();
  EXPECT_TRUE(waited);
  EXPECT_EQ(error, asio::error::timed_out);
  EXPECT_EQ(result, "done");
}

TEST(Published, GetReturnsTheLastSetValue) {
  Published<int> value;
  EXPECT_EQ(value.get(), 0);
  value.set(4);
  value.set(5);
  EXPECT_EQ(value.get(), 5);
}

}  // namespace
}  // namespace tether::client
