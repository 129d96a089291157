// The client skeleton's sans-protocol parts: the event handler list's contract, require(), the manual clock.
#include <gtest/gtest.h>

#include <boost/asio/error.hpp>
#include <boost/asio/io_context.hpp>

#include <stdexcept>
#include <string>
#include <vector>

#include "tether/client/client_skeleton.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/core/wakeup.hpp"

namespace tether::client {
namespace {

TEST(EventHandlers, EveryHandlerSeesEveryEventInTheOrderTheyWereAdded) {
  EventHandlers<int> handlers;
  std::vector<std::string> seen;
  const auto a = handlers.add([&](const int& e) { seen.push_back("a" + std::to_string(e)); });
  handlers.add([&](const int& e) { seen.push_back("b" + std::to_string(e)); });
  EXPECT_EQ(handlers.add(nullptr), 0u);  // an empty handler is not added
  handlers.emit(1);
  handlers.remove(a);
  handlers.emit(2);
  EXPECT_EQ(seen, (std::vector<std::string>{"a1", "b1", "b2"}));
}

TEST(EventHandlers, AThrowingHandlerIsCaughtAndTheOthersStillSeeTheEvent) {
  EventHandlers<int> handlers;
  int after = 0;
  int throwing_calls = 0;
  handlers.add([&](const int&) {
    ++throwing_calls;
    throw std::runtime_error("application bug");
  });
  handlers.add([&](const int&) { ++after; });
  EXPECT_NO_THROW(handlers.emit(1));
  EXPECT_NO_THROW(handlers.emit(2));
  EXPECT_EQ(after, 2);
  EXPECT_EQ(throwing_calls, 2);  // it stays registered
}

TEST(ClientSkeleton, RequireThrowsTheErrorCodeOfTheErrorForm) {
  EXPECT_EQ(require([](error_code&) { return 5; }, "call"), 5);
  try {
    require([](error_code& e) { e = boost::asio::error::timed_out; }, "elcano send");
    FAIL() << "no throw";
  } catch (const boost::system::system_error& error) {
    EXPECT_EQ(error.code(), boost::asio::error::timed_out);
    EXPECT_NE(std::string(error.what()).find("elcano send"), std::string::npos);
  }
  EXPECT_THROW(require_stream(nullptr, "romi::Client"), std::invalid_argument);
}

TEST(Wakeup, ConsiderKeepsTheEarliestArmedDeadlineAcrossTheWrap) {
  Deadline wake;
  consider(wake, Deadline());  // disarmed never wins
  EXPECT_FALSE(wake.armed());
  consider(wake, deadline_at(0xFFFFFFF0u));
  consider(wake, deadline_at(0x10u));  // after the wrap: later
  EXPECT_EQ(wake.at(), 0xFFFFFFF0u);
  consider(wake, deadline_at(0xFFFFFF00u));
  EXPECT_EQ(wake.at(), 0xFFFFFF00u);
}

TEST(ManualClock, WaitsCompleteWhenTheClockReachesThemInTheirOrder) {
  boost::asio::io_context io;
  auto clock = testing::ManualClock::create(0xFFFFFF00u);  // across the 32-bit wrap
  auto early = clock->make_timer(io.get_executor());
  auto late = clock->make_timer(io.get_executor());
  auto cancelled = clock->make_timer(io.get_executor());
  std::vector<std::string> done;
  late->wait_until(0x20u, [&](error_code e) { done.push_back(e ? "late aborted" : "late"); });
  early->wait_until(0xFFFFFF80u, [&](error_code e) { done.push_back(e ? "early aborted" : "early"); });
  cancelled->wait_until(0x10u, [&](error_code e) { done.push_back(e ? "cancelled aborted" : "cancelled"); });
  cancelled->cancel();
  io.poll();
  io.restart();
  EXPECT_EQ(done, (std::vector<std::string>{"cancelled aborted"}));
  EXPECT_EQ(clock->pending(), 2u);
  clock->advance(0x7F);  // one short of the early wait
  io.poll();
  io.restart();
  EXPECT_EQ(done.size(), 1u);
  clock->advance(0x200);  // both due: completed in the order of their instants
  io.poll();
  EXPECT_EQ(done, (std::vector<std::string>{"cancelled aborted", "early", "late"}));
  EXPECT_EQ(clock->pending(), 0u);
}

}  // namespace
}  // namespace tether::client
