// PendingOperations: the pending-operation list every codec client keeps (complete, fail_all, cancel,
// deadlines), on its own and inside a minimal link whose operations are cancelled through their
// cancellation slots and expire on a manual clock.
#include <gtest/gtest.h>

#include <boost/asio/error.hpp>
#include <boost/asio/io_context.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "tether/client/client_skeleton.hpp"
#include "tether/client/pending_operations.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/in_memory_stream.hpp"

namespace tether::client {
namespace {

using namespace std::chrono_literals;

// What the tests' operations carry: a name, and whether the client took it out of its engine.
struct TestOperationState {
  std::string name;
  bool finished_by_client = false;
};
using TestOperations = PendingOperations<void(error_code, std::string), TestOperationState>;
using TestResults = std::tuple<error_code, std::string>;

// A handler that records "<name>:<error or ok>:<result>" in `log`.
TestOperations::Handler recorder(std::vector<std::string>& log, std::string name) {
  return [&log, name](error_code error, std::string result) {
    log.push_back(name + ":" + (error ? error.message() : std::string("ok")) + ":" + result);
  };
}

Deadline pending_deadline_at(Millis at) {
  Deadline deadline;
  deadline.arm_at(at);
  return deadline;
}

TEST(PendingOperations, CompletionIsPostedAfterTheHookAndRemovesTheEntry) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  int published = 0;
  TestOperations operations(io.get_executor(), [&] {
    ++published;
    log.push_back("publish");
  });
  const auto a = operations.add(1, recorder(log, "a"), {"a"});
  operations.add(0, {}, {"own work"});  // the client's own: no handler
  operations.add(2, recorder(log, "b"), {"b"});
  ASSERT_EQ(operations.size(), 3u);

  const auto next = operations.complete(a, error_code(), "answer");
  EXPECT_EQ(next->state.name, "own work");
  EXPECT_EQ(log, (std::vector<std::string>{"publish"}));  // posted, not run inline
  operations.complete(next, error_code(), "dropped");     // nothing to post for the client's own work
  EXPECT_EQ(published, 1);
  EXPECT_EQ(operations.size(), 1u);
  EXPECT_EQ(operations.find(0), operations.end());  // id 0 is never the caller's
  EXPECT_EQ(operations.find(2)->state.name, "b");

  io.poll();
  EXPECT_EQ(log, (std::vector<std::string>{"publish", "a:ok:answer"}));
}

TEST(PendingOperations, FailAllCompletesEveryEntryInAcceptanceOrder) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  TestOperations operations(io.get_executor());
  operations.add(7, recorder(log, "first"), {"first"});
  operations.add(0, {}, {"replay"});
  operations.add(3, recorder(log, "second"), {"second"});
  std::vector<std::string> finished;  // what the client undid, own work included
  operations.fail_all([&](TestOperations::Operation& operation) {
    finished.push_back(operation.state.name);
    return TestResults(boost::asio::error::operation_aborted, operation.state.name);
  });
  EXPECT_TRUE(operations.empty());
  EXPECT_EQ(finished, (std::vector<std::string>{"first", "replay", "second"}));
  io.poll();
  const std::string aborted = error_code(boost::asio::error::operation_aborted).message();
  EXPECT_EQ(log, (std::vector<std::string>{"first:" + aborted + ":first", "second:" + aborted + ":second"}));
}

TEST(PendingOperations, ACompletionThatStartsAnotherOperationLeavesItPending) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  TestOperations operations(io.get_executor());
  operations.add(1, [&](error_code, std::string) {
    log.push_back("first done");
    operations.add(2, recorder(log, "second"), {"second"});  // the caller's next operation
  }, {"first"});
  operations.complete(operations.begin(), error_code(), "");
  io.poll();
  ASSERT_EQ(operations.size(), 1u);
  EXPECT_EQ(operations.begin()->state.name, "second");

  // The same from a completion of fail_all: the new operation is not failed with the old ones.
  operations.begin()->handler = [&](error_code, std::string) {
    log.push_back("second failed");
    operations.add(3, recorder(log, "third"), {"third"});
  };
  operations.fail_all([](TestOperations::Operation&) { return TestResults(boost::asio::error::broken_pipe, ""); });
  io.restart();
  io.poll();
  ASSERT_EQ(operations.size(), 1u);
  EXPECT_EQ(operations.begin()->state.name, "third");
  EXPECT_EQ(log, (std::vector<std::string>{"first done", "second failed"}));
}

TEST(PendingOperations, CancelCompletesOnlyThatOperationAfterTheClientsPart) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  TestOperations operations(io.get_executor());
  operations.add(1, recorder(log, "a"), {"a"});
  operations.add(2, recorder(log, "b"), {"b"});
  const auto finish = [](TestOperations::Operation& operation) {
    operation.state.finished_by_client = true;
    return TestResults(boost::asio::error::operation_aborted, operation.state.name + " cancelled");
  };
  EXPECT_TRUE(operations.cancel(2, finish));
  EXPECT_FALSE(operations.cancel(2, finish));   // already completed
  EXPECT_FALSE(operations.cancel(99, finish));  // unknown
  EXPECT_FALSE(operations.cancel(0, finish));   // never the client's own work
  io.poll();
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0], "b:" + error_code(boost::asio::error::operation_aborted).message() + ":b cancelled");
  ASSERT_EQ(operations.size(), 1u);
  EXPECT_FALSE(operations.begin()->state.finished_by_client);
}

TEST(PendingOperations, DeadlinesExpireInOrderAcrossTheWrapAndOnlyArmedOnes) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  TestOperations operations(io.get_executor());
  operations.add(1, recorder(log, "late"), {"late"}, pending_deadline_at(0x20u));
  operations.add(2, recorder(log, "none"), {"none"});
  operations.add(3, recorder(log, "early"), {"early"}, pending_deadline_at(0xFFFFFFF0u));
  EXPECT_EQ(operations.next_deadline().at(), 0xFFFFFFF0u);  // before the wrap: earlier
  const auto timed_out = [](TestOperations::Operation& operation) {
    return TestResults(boost::asio::error::timed_out, operation.state.name);
  };
  operations.expire(0xFFFFFFEFu, timed_out);
  EXPECT_EQ(operations.size(), 3u);
  operations.expire(0xFFFFFFF0u, timed_out);  // reached exactly
  EXPECT_EQ(operations.size(), 2u);
  EXPECT_EQ(operations.next_deadline().at(), 0x20u);
  operations.expire(0x100u, timed_out);
  ASSERT_EQ(operations.size(), 1u);
  EXPECT_FALSE(operations.next_deadline().armed());
  io.poll();
  const std::string timeout = error_code(boost::asio::error::timed_out).message();
  EXPECT_EQ(log, (std::vector<std::string>{"early:" + timeout + ":early", "late:" + timeout + ":late"}));
}

TEST(PendingOperations, ExpireIfExpiresOnlyWhatItSelectsSoAClientOrdersKindsOfOperations) {
  boost::asio::io_context io;
  std::vector<std::string> log;
  TestOperations operations(io.get_executor());
  operations.add(1, recorder(log, "written"), {"written"}, pending_deadline_at(100));
  operations.add(2, recorder(log, "queued"), {"queued"}, pending_deadline_at(100));
  const auto timed_out = [](TestOperations::Operation& operation) {
    return TestResults(boost::asio::error::timed_out, operation.state.name);
  };
  operations.expire_if(100, [](const TestOperations::Operation& operation) { return operation.state.name == "queued"; },
                       timed_out);
  ASSERT_EQ(operations.size(), 1u);
  EXPECT_EQ(operations.next_deadline().at(), 100u);  // still due
  operations.expire(100, timed_out);
  EXPECT_TRUE(operations.empty());
  io.poll();
  const std::string timeout = error_code(boost::asio::error::timed_out).message();
  EXPECT_EQ(log, (std::vector<std::string>{"queued:" + timeout + ":queued", "written:" + timeout + ":written"}));
}

TEST(PendingOperations, DestroyedWithEntriesLeftTheirHandlersAreReleasedNotCalled) {
  boost::asio::io_context io;
  auto held = std::make_shared<int>(0);
  int calls = 0;
  {
    TestOperations operations(io.get_executor());
    operations.add(1, [held, &calls](error_code, std::string) { ++calls; }, {"a"});
    operations.add(0, {}, {"own"});
    EXPECT_EQ(held.use_count(), 2);
  }
  io.poll();
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(held.use_count(), 1);  // the handler (and what it held) went with the list
}

// A client with no protocol over a real link: operations wait until the test completes them, expire at
// their deadline on the link's clock, are cancelled through their cancellation slots and fail at close.
class PendingOperationsLink final : public ClientLink {
 public:
  PendingOperationsLink(std::shared_ptr<transports::ByteStream> stream, std::shared_ptr<LinkClock> clock)
      : ClientLink(std::move(stream), std::move(clock)), pending_(executor(), [this] { ++published; }) {}

  void start() {
    post_to_strand([this] { start_reading(); });
  }
  // Accepts an operation expiring `timeout` ms from now (0: no deadline).
  void submit(OperationId operation, TestOperations::Handler handler, std::string name, Duration timeout) {
    post_to_strand([this, operation, handler = std::move(handler), name, timeout]() mutable {
      Deadline deadline;
      if (timeout > 0) deadline.arm(now(), timeout);
      pending_.add(operation, std::move(handler), {name}, deadline);
      arm_timer(pending_.next_deadline());
    });
  }
  // Completes the oldest operation with `result`.
  void answer(std::string result) {
    post_to_strand([this, result] {
      if (!pending_.empty()) pending_.complete(pending_.begin(), error_code(), result);
    });
  }

  int published = 0;  // completions posted (strand)

 private:
  void on_bytes(const std::uint8_t*, std::size_t) override {}
  void on_timer() override {
    pending_.expire(now(), [](TestOperations::Operation& operation) {
      return TestResults(boost::asio::error::timed_out, operation.state.name);
    });
    arm_timer(pending_.next_deadline());
  }
  void on_link_failed(const error_code& error) override {
    pending_.fail_all([&](TestOperations::Operation&) { return TestResults(error, ""); });
  }
  void on_closed() override {
    pending_.fail_all(
        [](TestOperations::Operation&) { return TestResults(boost::asio::error::operation_aborted, "closed"); });
  }
  void on_cancel(OperationId operation) override {
    pending_.cancel(operation, [](TestOperations::Operation& cancelled) {
      return TestResults(boost::asio::error::operation_aborted, cancelled.state.name);
    });
  }

  TestOperations pending_;
};

struct StartTestOperation {
  template <typename Handler>
  void operator()(const std::shared_ptr<PendingOperationsLink>& impl, ClientLink::OperationId operation,
                  Handler handler, std::string name, Duration timeout) const {
    impl->submit(operation, std::move(handler), std::move(name), timeout);
  }
};

bool run_pending_until(boost::asio::io_context& io, const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!done() && std::chrono::steady_clock::now() < deadline) {
    io.restart();
    io.run_for(5ms);
  }
  return done();
}

TEST(PendingOperations, InALinkACancellationSlotCancelsItsOperationAloneAndDeadlinesUseTheLinksClock) {
  boost::asio::io_context io;
  auto [near, far] = transports::InMemoryStream::make_pair(io.get_executor());
  auto clock = testing::ManualClock::create(0xFFFFFF00u);
  auto link = std::make_shared<PendingOperationsLink>(near, clock);
  link->start();
  const ClientRef<PendingOperationsLink> ref(link);

  std::vector<std::string> log;
  const CancellationSignal cancel_second;
  ref.initiate<void(error_code, std::string)>(recorder(log, "first"), StartTestOperation(), std::string("first"),
                                              Duration(0));
  ref.initiate<void(error_code, std::string)>(bind_cancellation(cancel_second, recorder(log, "second")),
                                              StartTestOperation(), std::string("second"), Duration(0));
  ref.initiate<void(error_code, std::string)>(recorder(log, "timed"), StartTestOperation(), std::string("timed"),
                                              Duration(300));
  ASSERT_TRUE(run_pending_until(io, [&] { return clock->pending() == 1; }));  // the deadline is armed
  Millis due = 0;
  ASSERT_TRUE(clock->next_due(due));
  EXPECT_EQ(due, static_cast<Millis>(0xFFFFFF00u + 300u));  // across the wrap

  cancel_second.emit();
  ASSERT_TRUE(run_pending_until(io, [&] { return log.size() == 1; }));
  EXPECT_EQ(log[0], "second:" + error_code(boost::asio::error::operation_aborted).message() + ":second");
  cancel_second.emit();  // completed already: nothing happens

  clock->advance(299);
  io.restart();
  io.poll();
  EXPECT_EQ(log.size(), 1u);  // not yet
  clock->advance(1);
  ASSERT_TRUE(run_pending_until(io, [&] { return log.size() == 2; }));
  EXPECT_EQ(log[1], "timed:" + error_code(boost::asio::error::timed_out).message() + ":timed");

  link->answer("reply");
  ASSERT_TRUE(run_pending_until(io, [&] { return log.size() == 3; }));
  EXPECT_EQ(log[2], "first:ok:reply");

  ref.initiate<void(error_code, std::string)>(recorder(log, "left"), StartTestOperation(), std::string("left"),
                                              Duration(0));
  link->close();
  ASSERT_TRUE(run_pending_until(io, [&] { return log.size() == 4; }));
  EXPECT_EQ(log[3], "left:" + error_code(boost::asio::error::operation_aborted).message() + ":closed");
  EXPECT_EQ(link->published, 4);  // the hook ran before each completion
  (void)far;
}

}  // namespace
}  // namespace tether::client
