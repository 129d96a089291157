// VirtualUnoClock's contract (link_clock.hpp) on a board driven by run_for(): simulated time moves only
// when the test advances it, and the timers' completions run on an io_context this thread runs, so what
// completes when is deterministic; wall-clock waits only give the polls time to run (and bound a hang).
#include <gtest/gtest.h>

#include <boost/asio/error.hpp>
#include <boost/asio/io_context.hpp>

#include <chrono>
#include <memory>
#include <optional>
#include <thread>

#include "test_support.hpp"
#include "tether/transports/virtual_uno_clock.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::transports {
namespace {

using namespace std::chrono_literals;
using test::echo_options;

/// Records the one completion of a wait.
struct Completion {
  std::optional<boost::system::error_code> error;
  Millis clock_then = 0;  // the clock's reading when the handler ran
  int calls = 0;
  client::LinkTimer::Handler handler(const client::LinkClock& clock) {
    return [this, &clock](boost::system::error_code e) {
      error = e;
      clock_then = clock.now();
      ++calls;
    };
  }
};

/// Runs `io` until `done()` (wall bound: only a broken clock reaches it).
template <typename Done>
bool run_until(boost::asio::io_context& io, Done done, std::chrono::milliseconds limit = 20s) {
  const auto give_up = std::chrono::steady_clock::now() + limit;
  while (!done() && std::chrono::steady_clock::now() < give_up) {
    io.restart();
    io.run_one_for(10ms);
  }
  return done();
}

/// Lets the pending polls run for a while of wall time (many poll steps) without moving the board.
void let_polls_run(boost::asio::io_context& io) {
  io.restart();
  io.run_for(30ms);
}

TEST(VirtualUnoClock, NowIsTheBoardsSimulatedMilliseconds) {
  VirtualUno board(echo_options());
  const auto clock = VirtualUnoClock::create(board);
  EXPECT_EQ(clock->now(), 0u);
  board.run_for(37ms);
  EXPECT_EQ(clock->now(), static_cast<Millis>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                                  board.simulated_time())
                                                  .count()));
  EXPECT_GE(clock->now(), 37u);
  EXPECT_LT(clock->now(), 39u);
}

TEST(VirtualUnoClock, AWaitCompletesOnceTheSimulatedTimeReachesItsInstantAndNotBefore) {
  VirtualUno board(echo_options());
  board.run_for(10ms);
  const auto clock = VirtualUnoClock::create(board);
  boost::asio::io_context io;
  const auto timer = clock->make_timer(io.get_executor());
  Completion completion;
  const Millis at = clock->now() + 50;
  timer->wait_until(at, completion.handler(*clock));
  EXPECT_EQ(completion.calls, 0);  // never inside wait_until

  board.run_for(std::chrono::milliseconds(at - clock->now() - 1));  // one simulated ms short
  let_polls_run(io);
  EXPECT_EQ(completion.calls, 0) << "completed at " << clock->now() << " before its instant " << at;

  board.run_for(1ms);
  ASSERT_TRUE(run_until(io, [&] { return completion.calls > 0; }));
  EXPECT_EQ(*completion.error, boost::system::error_code());
  EXPECT_TRUE(tick_reached(completion.clock_then, at));
  let_polls_run(io);
  EXPECT_EQ(completion.calls, 1);  // exactly once
}

TEST(VirtualUnoClock, AnInstantAlreadyReachedCompletesWithoutTheBoardMovingButNotInsideTheCall) {
  VirtualUno board(echo_options());
  board.run_for(20ms);
  const auto clock = VirtualUnoClock::create(board);
  boost::asio::io_context io;
  const auto timer = clock->make_timer(io.get_executor());
  for (const Millis at : {clock->now(), static_cast<Millis>(clock->now() - 5),
                          static_cast<Millis>(clock->now() - 1000)}) {  // the last one wraps below 0
    Completion completion;
    timer->wait_until(at, completion.handler(*clock));
    EXPECT_EQ(completion.calls, 0);
    ASSERT_TRUE(run_until(io, [&] { return completion.calls > 0; })) << at;
    EXPECT_EQ(*completion.error, boost::system::error_code()) << at;
  }
}

TEST(VirtualUnoClock, CancelReplaceAndDestroyAbortThePendingWaitOnce) {
  VirtualUno board(echo_options());
  const auto clock = VirtualUnoClock::create(board);
  boost::asio::io_context io;
  auto timer = clock->make_timer(io.get_executor());

  Completion cancelled;
  timer->wait_until(clock->now() + 5, cancelled.handler(*clock));
  timer->cancel();
  EXPECT_EQ(cancelled.calls, 0);  // never inside cancel
  timer->cancel();                // nothing pending: nothing happens
  ASSERT_TRUE(run_until(io, [&] { return cancelled.calls > 0; }));
  EXPECT_EQ(*cancelled.error, boost::asio::error::operation_aborted);

  Completion replaced;
  Completion replacement;
  timer->wait_until(clock->now() + 5, replaced.handler(*clock));
  timer->wait_until(clock->now() + 10, replacement.handler(*clock));
  ASSERT_TRUE(run_until(io, [&] { return replaced.calls > 0; }));
  EXPECT_EQ(*replaced.error, boost::asio::error::operation_aborted);
  board.run_for(5ms);
  let_polls_run(io);
  EXPECT_EQ(replacement.calls, 0);  // the replaced instant passed; the replacement's has not
  board.run_for(5ms);
  ASSERT_TRUE(run_until(io, [&] { return replacement.calls > 0; }));
  EXPECT_EQ(*replacement.error, boost::system::error_code());

  Completion destroyed;
  timer->wait_until(clock->now() + 5, destroyed.handler(*clock));
  let_polls_run(io);  // polls in flight when the timer goes
  timer.reset();
  board.run_for(10ms);
  ASSERT_TRUE(run_until(io, [&] { return destroyed.calls > 0; }));
  EXPECT_EQ(*destroyed.error, boost::asio::error::operation_aborted);
  let_polls_run(io);
  EXPECT_EQ(cancelled.calls + replaced.calls + replacement.calls + destroyed.calls, 4);
}

TEST(VirtualUnoClock, FollowsABoardRunningOnItsThreadAndKeepsItsStreamsBoardAlive) {
  boost::asio::io_context io;
  std::shared_ptr<client::LinkClock> clock;
  {
    auto stream = VirtualUnoStream::open(io.get_executor(), echo_options());
    clock = VirtualUnoClock::create(stream);
  }  // the clock holds the stream, whose board keeps running
  const auto timer = clock->make_timer(io.get_executor());
  Completion completion;
  const Millis at = clock->now() + 200;
  timer->wait_until(at, completion.handler(*clock));
  ASSERT_TRUE(run_until(io, [&] { return completion.calls > 0; }));
  EXPECT_EQ(*completion.error, boost::system::error_code());
  EXPECT_TRUE(tick_reached(completion.clock_then, at));
}

}  // namespace
}  // namespace tether::transports
