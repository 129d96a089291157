// The rpc client against the real device runtime (ArmDevice: codecs/rpc/device on the host) over an
// in-memory link, on a manual clock: calls, errors, re-sends, streams, resets, a device of another schema.
#include "tether/rpc/client.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/reflection.h>
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>

#include <atomic>
#include <future>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "arm_device.hpp"
#include "arm_peer.hpp"
#include "tether/testing/eventually.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/client/testing/event_log.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/testing/scripted_peer.hpp"

namespace {

using namespace std::chrono_literals;
using tether::Millis;
using tether::rpc::CallResult;
using tether::rpc::Client;
using tether::rpc::RpcError;
using tether::rpc::Schema;
using tether::rpc::testing::ArmDevice;
using tether::testing::eventually;
namespace events = tether::rpc::events;
namespace pb = google::protobuf;

const std::string kSchemas = TETHER_RPC_TEST_SCHEMAS;
using tether::rpc::testing::ArmPeer;

tether::rpc::Options test_options(std::shared_ptr<tether::client::LinkClock> clock) {
  tether::rpc::Options options;
  options.clock = std::move(clock);
  options.first_message_id = 100;
  options.timing.ping_period = 0;  // predictable ids; the tests stay below the device's 10 s failsafe
  options.timing.processing_margin = 150;
  options.timing.call_budget = 2000;
  options.timing.queue_timeout = 3000;
  options.timing.hello_timeout = 1000;
  return options;
}

struct Link {
  explicit Link(std::optional<std::uint64_t> device_hash = std::nullopt, std::uint32_t session = 0xC0FFEE)
      : clock(tether::client::testing::ManualClock::create()),
        schema_hash(Schema::load(kSchemas + "/arm.proto").hash()) {
    auto [host_end, device_end] = tether::transports::InMemoryStream::make_pair(io.executor());
    peer = ArmPeer::start(device_end, device_hash.value_or(schema_hash), clock);
    peer->boot(session);
    client.emplace(host_end, Schema::load(kSchemas + "/arm.proto"), test_options(clock), log.handler());
  }
  ~Link() {
    if (client) client->close();
    peer->close();
  }

  // Time passes for both ends, 1 ms of simulated time per 1 ms pause: a deadline passes before its answer
  // is back only if the machine stalls for the deadline's whole window of wall time, and then the
  // assertions below still hold (they allow the re-sends a stall causes: exactly-once does not change).
  void step() {
    clock->advance(1);
    peer->poll();
    std::this_thread::sleep_for(1ms);
  }
  // Advances the clock by `ms`, polling the device at each step.
  void run_for(tether::Duration ms) {
    for (tether::Duration i = 0; i < ms; ++i) step();
  }
  // Advances time until `done()` (at most `limit` ms of simulated time).
  bool run_until(const std::function<bool()>& done, tether::Duration limit = 10000) {
    for (tether::Duration i = 0; i < limit && !done(); ++i) step();
    return done();
  }
  // A call started now, its result when it completed while time ran.
  std::pair<tether::rpc::error_code, CallResult> run_call(const std::string& method, const pb::Message& request) {
    std::promise<std::pair<tether::rpc::error_code, CallResult>> done;
    auto future = done.get_future();
    client->async_call(method, request, [&done](tether::rpc::error_code e, CallResult r) {
      done.set_value({e, std::move(r)});
    });
    EXPECT_TRUE(run_until([&] { return future.wait_for(0s) == std::future_status::ready; }));
    return future.get();
  }

  std::shared_ptr<pb::Message> move_request(std::uint32_t joint, std::int32_t angle) {
    auto request = client->new_request("MoveJoint");
    const pb::Reflection& r = *request->GetReflection();
    r.SetUInt32(request.get(), request->GetDescriptor()->FindFieldByName("joint"), joint);
    r.SetInt32(request.get(), request->GetDescriptor()->FindFieldByName("angle_cdeg"), angle);
    return request;
  }
  static std::int32_t reached(const CallResult& result) {
    return result.reply->GetReflection()->GetInt32(*result.reply, result.reply->GetDescriptor()->FindFieldByName("reached_cdeg"));
  }
  bool ready() {
    return run_until([&] { return client->session().established; });
  }

  tether::transports::IoThread io;
  std::shared_ptr<tether::client::testing::ManualClock> clock;
  std::uint64_t schema_hash;
  tether::client::testing::EventLog<tether::rpc::Event> log;
  std::shared_ptr<ArmPeer> peer;
  std::optional<Client> client;
};

// `stream.close_and_wait` on a thread of its own while the test drives the link's simulated time: its error,
// or nothing when it did not end within the run (the client is then closed, which ends the wait).
std::optional<tether::rpc::error_code> close_and_wait_driven(Link& link, tether::rpc::Stream& stream) {
  std::promise<tether::rpc::error_code> closed;
  auto done = closed.get_future();
  std::thread closer([&] {
    tether::rpc::error_code error;
    stream.close_and_wait(error);
    closed.set_value(error);
  });
  const bool ended = link.run_until([&] { return done.wait_for(0s) == std::future_status::ready; });
  if (!ended) link.client->close();
  closer.join();
  if (!ended) return std::nullopt;
  return done.get();
}

// A Watch stream every 50 ms whose messages count into `messages`.
tether::rpc::Stream counted_watch(Link& link, std::atomic<int>& messages) {
  return link.client->open_stream("Watch", *link.client->new_request("Watch"), 50ms,
                                  [&messages](const tether::rpc::error_code& error, const tether::rpc::StreamMessage&) {
                                    if (!error) ++messages;
                                  });
}

TEST(RpcClient, HelloEstablishesTheSessionWithTheDevicesSchema) {
  Link link;
  ASSERT_TRUE(link.ready());
  const auto session = link.client->session();
  EXPECT_EQ(session.session_id, 0xC0FFEEu);
  EXPECT_EQ(session.device_hash, link.schema_hash);
  ASSERT_TRUE(link.log.wait_for<events::SessionEstablished>(1));
  EXPECT_TRUE(link.log.of<events::SessionEstablished>()[0].first);
  link.client->wait_ready();  // already: at once
  EXPECT_GE(link.client->counters().hellos_sent, 1u);
}

TEST(RpcClient, ACallGetsItsTypedReplyAndJsonWorksBothWays) {
  Link link;
  ASSERT_TRUE(link.ready());
  const auto [error, result] = link.run_call("MoveJoint", *link.move_request(2, -4500));
  ASSERT_FALSE(error) << error.message();
  EXPECT_EQ(Link::reached(result), -4501);
  EXPECT_GE(result.attempts, 1);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.moves(); }), 1);

  std::string json;
  std::thread caller([&] { json = link.client->call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 300})"); });
  ASSERT_TRUE(link.run_until([&] { return link.peer->read([](const ArmDevice& d) { return d.moves(); }) == 2; }));
  caller.join();
  EXPECT_EQ(json, R"({"reachedCdeg":299})");
  EXPECT_EQ(link.client->counters().replies, 2u);
}

TEST(RpcClient, AHandlerErrorComesWithItsCodeAndText) {
  Link link;
  ASSERT_TRUE(link.ready());
  link.peer->with_device([](ArmDevice& d) { d.fail_moves(42, "joint 3 is locked"); });
  const auto [error, result] = link.run_call("MoveJoint", *link.move_request(3, 0));
  EXPECT_EQ(error, RpcError::device_error);
  EXPECT_EQ(result.device_error.code, 42);
  EXPECT_EQ(result.device_error.text, "joint 3 is locked");
  EXPECT_EQ(result.reply, nullptr);

  std::optional<tether::rpc::CallError> thrown;
  std::thread caller([&] {
    try {
      link.client->call("MoveJoint", *link.move_request(3, 0));
    } catch (const tether::rpc::CallError& e) {
      thrown.emplace(e);
    }
  });
  ASSERT_TRUE(link.run_until([&] { return link.peer->read([](const ArmDevice& d) { return d.moves(); }) == 2; }));
  caller.join();
  ASSERT_TRUE(thrown);
  EXPECT_STREQ(thrown->what(), "MoveJoint: device error 42: joint 3 is locked");
  EXPECT_EQ(thrown->device_error().code, 42);
}

TEST(RpcClient, WhatTheSchemaRefusesFailsBeforeAnythingIsWritten) {
  Link link;
  ASSERT_TRUE(link.ready());
  EXPECT_EQ(link.run_call("Fly", *link.move_request(1, 1)).first, RpcError::unknown_method);
  EXPECT_EQ(link.run_call("Watch", *link.client->new_request("Watch")).first, RpcError::wrong_kind);
  EXPECT_EQ(link.run_call("MoveJoint", *link.client->new_request("Watch")).first, RpcError::invalid_request);
  try {
    link.client->call_json("MoveJoint", R"({"joint": "two"})");
    ADD_FAILURE() << "no exception";
  } catch (const boost::system::system_error& e) {
    EXPECT_EQ(e.code(), RpcError::invalid_request);
    EXPECT_NE(std::string(e.what()).find("MoveJoint: "), std::string::npos) << e.what();
  }
  EXPECT_THROW(link.client->new_request("Fly"), std::invalid_argument);
  for (const auto period : {0ms, 65536ms}) {
    try {
      (void)link.client->open_stream("Watch", *link.client->new_request("Watch"), period,
                                     [](const tether::rpc::error_code&, const tether::rpc::StreamMessage&) {});
      ADD_FAILURE() << "no exception";
    } catch (const boost::system::system_error& e) {  // the request is fine: only the period is named
      EXPECT_EQ(e.code(), boost::system::errc::invalid_argument);
      EXPECT_NE(std::string(e.what()).find("open_stream Watch: the period, " + std::to_string(period.count()) +
                                           " ms, is outside 1..65535 ms"),
                std::string::npos)
          << e.what();
      EXPECT_EQ(std::string(e.what()).find("request"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(link.client->counters().messages_sent, 0u);
}

TEST(RpcClient, ARefusalOfARequestThatDoesNotDecodeHintsAtTheBounds) {
  const tether::rpc::CallError refused(RpcError::refused, "Configure", {0xFF02, "request does not decode"});
  EXPECT_STREQ(refused.what(), "Configure: refused 65282: request does not decode (a field over its .options bound?)");
  const tether::rpc::CallError other(RpcError::refused, "Configure", {0xFF01, "unknown method"});
  EXPECT_STREQ(other.what(), "Configure: refused 65281: unknown method");
}

TEST(RpcClient, ALostAnswerIsFetchedAgainFromTheDevicesCacheWithoutASecondRun) {
  Link link;
  ASSERT_TRUE(link.ready());
  link.peer->drop_answers(1);  // the Reply; the Ack arrives alone
  const auto [error, result] = link.run_call("MoveJoint", *link.move_request(2, 10));
  ASSERT_FALSE(error) << error.message();
  EXPECT_EQ(Link::reached(result), 9);
  EXPECT_GE(result.attempts, 2);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.moves(); }), 1);
  EXPECT_GE(link.peer->read([](const ArmDevice& d) { return d.duplicates(); }), 1u);
}

TEST(RpcClient, ALostRequestIsSentAgainWhenItsWindowPasses) {
  Link link;
  ASSERT_TRUE(link.ready());
  link.peer->drop_requests(1);
  const auto [error, result] = link.run_call("MoveJoint", *link.move_request(2, 10));
  ASSERT_FALSE(error) << error.message();
  EXPECT_GE(result.attempts, 2);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.moves(); }), 1);
  EXPECT_GE(link.client->counters().link.retries, 1u);
}

TEST(RpcClient, ASilentDeviceTimesTheCallOut) {
  Link link;
  ASSERT_TRUE(link.ready());
  link.peer->deaf(true);
  const Millis start = link.clock->now();
  const auto [error, result] = link.run_call("MoveJoint", *link.move_request(2, 10));
  EXPECT_EQ(error, RpcError::timed_out);
  EXPECT_GE(tether::tick_difference(link.clock->now(), start), 2000);
  EXPECT_GT(result.attempts, 1);
}

TEST(RpcClient, AStreamDeliversEveryPeriodUntilClosed) {
  Link link;
  ASSERT_TRUE(link.ready());
  std::mutex mutex;
  std::vector<std::uint32_t> seqs;
  std::vector<std::int32_t> firsts;
  tether::rpc::Stream watch = link.client->open_stream(
      "Watch", *link.client->new_request("Watch"), 100ms,
      [&](const tether::rpc::error_code& error, const tether::rpc::StreamMessage& message) {
        ASSERT_FALSE(error) << error.message();
        const auto& m = *message.message;
        const pb::FieldDescriptor* angles = m.GetDescriptor()->FindFieldByName("angles_cdeg");
        const std::lock_guard<std::mutex> lock(mutex);
        seqs.push_back(message.seq);
        firsts.push_back(m.GetReflection()->GetRepeatedInt32(m, angles, 0));
      });
  // Open from the call on, while the client's strand takes the stream over (it once read closed for a moment).
  bool open_throughout = true;
  ASSERT_TRUE(link.run_until([&] {
    open_throughout = open_throughout && watch.is_open();
    const std::lock_guard<std::mutex> lock(mutex);
    return seqs.size() >= 3;
  }));
  EXPECT_TRUE(open_throughout);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(seqs[0], 0u);
    EXPECT_EQ(seqs[1], 1u);
    EXPECT_EQ(seqs[2], 2u);
    EXPECT_EQ(firsts[2], 3);
  }
  watch.close();
  EXPECT_FALSE(watch.is_open());
  ASSERT_TRUE(link.run_until([&] { return link.peer->read([](const ArmDevice& d) { return d.open_streams(); }) == 0; }));
  const auto sent = link.peer->read([](const ArmDevice& d) { return d.stream_messages(); });
  link.run_for(500);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.stream_messages(); }), sent);
}

// close_and_wait returns once the device acked the close: the device runs no stream from then on, which
// a program that closes its client right after (`tether call --count N`) relies on.
TEST(RpcClient, CloseAndWaitReturnsOnceTheDeviceStoppedTheStream) {
  Link link;
  ASSERT_TRUE(link.ready());
  std::atomic<int> messages{0};
  tether::rpc::Stream watch = counted_watch(link, messages);
  ASSERT_TRUE(link.run_until([&] { return messages.load() >= 2; }));
  const auto closed = close_and_wait_driven(link, watch);
  ASSERT_TRUE(closed);
  EXPECT_FALSE(*closed);
  EXPECT_FALSE(watch.is_open());
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.open_streams(); }), 0);

  // Closed while its open is on its way (its first frame lost): the wait covers the open's ack, then the
  // close's.
  link.peer->drop_requests(1);
  tether::rpc::Stream early = link.client->open_stream(
      "Watch", *link.client->new_request("Watch"), 50ms, [](const tether::rpc::error_code&, const tether::rpc::StreamMessage&) {});
  ASSERT_TRUE(link.run_until([&] { return link.client->counters().messages_sent >= 3; }));  // open, close, open
  const auto early_closed = close_and_wait_driven(link, early);
  ASSERT_TRUE(early_closed);
  EXPECT_FALSE(*early_closed);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.open_streams(); }), 0);

  tether::rpc::error_code again;
  early.close_and_wait(again);  // closed already: nothing to wait for
  EXPECT_FALSE(again);
}

// A device that no longer answers: the wait ends with the close's budget, or the caller's limit.
TEST(RpcClient, CloseAndWaitOnASilentDeviceTimesOut) {
  Link link;
  ASSERT_TRUE(link.ready());
  std::atomic<int> messages{0};
  const auto open = [&] {
    return counted_watch(link, messages);
  };
  tether::rpc::Stream watch = open();
  ASSERT_TRUE(link.run_until([&] { return messages.load() >= 1; }));
  link.peer->deaf(true);
  const Millis start = link.clock->now();
  const auto closed = close_and_wait_driven(link, watch);
  ASSERT_TRUE(closed);
  EXPECT_EQ(*closed, RpcError::timed_out);
  EXPECT_GE(tether::tick_difference(link.clock->now(), start), 2000);  // the call budget

  link.peer->deaf(false);
  messages = 0;
  tether::rpc::Stream second = open();
  ASSERT_TRUE(link.run_until([&] { return messages.load() >= 1; }));
  link.peer->deaf(true);
  tether::rpc::error_code error;
  second.close_and_wait(error, 20ms);  // no simulated time passes: only the limit ends the wait
  EXPECT_EQ(error, RpcError::timed_out);
  EXPECT_FALSE(second.is_open());
}

TEST(RpcClient, AfterADeviceResetTheSessionAndItsStreamsComeBack) {
  Link link;
  ASSERT_TRUE(link.ready());
  std::atomic<int> messages{0};
  tether::rpc::Stream watch = counted_watch(link, messages);
  ASSERT_TRUE(link.run_until([&] { return messages.load() >= 2; }));
  link.peer->boot(0xBEEF);  // the device restarts: no stream, a new session, ResetEvent
  ASSERT_TRUE(link.run_until([&] { return link.log.of<events::SessionEstablished>().size() >= 2; }));
  const auto resets = link.log.of<events::ResetDetected>();
  ASSERT_EQ(resets.size(), 1u);
  EXPECT_EQ(resets[0].previous, 0xC0FFEEu);
  EXPECT_EQ(resets[0].current, 0xBEEFu);
  EXPECT_EQ(link.log.of<events::SessionEstablished>()[1].streams_reopened, 1u);
  const int before = messages.load();
  ASSERT_TRUE(link.run_until([&] { return messages.load() >= before + 2; }));
  EXPECT_TRUE(watch.is_open());
  EXPECT_EQ(link.client->session().session_id, 0xBEEFu);
}

TEST(RpcClient, ADeviceOfAnotherSchemaIsRefusedNamingBothHashesAndTheFile) {
  Link link(0x1234);
  ASSERT_TRUE(link.run_until([&] { return !link.log.of<events::SchemaMismatch>().empty(); }));
  const auto mismatch = link.log.of<events::SchemaMismatch>()[0];
  EXPECT_EQ(mismatch.device_hash, 0x1234u);
  EXPECT_EQ(mismatch.schema_hash, link.schema_hash);
  const std::string expected = kSchemas + "/arm.proto: the device was built from another schema (its hash "
                               "0x0000000000001234, this schema's " + tether::rpc::format_hash(link.schema_hash) + ")";
  EXPECT_EQ(mismatch.text, expected);
  try {
    link.client->wait_ready();
    ADD_FAILURE() << "no exception";
  } catch (const boost::system::system_error& e) {
    EXPECT_EQ(e.code(), RpcError::schema_mismatch);
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
  EXPECT_EQ(link.run_call("MoveJoint", *link.move_request(1, 1)).first, RpcError::schema_mismatch);
  EXPECT_EQ(link.peer->read([](const ArmDevice& d) { return d.moves(); }), 0);
}

TEST(RpcClient, CloseCompletesPendingCallsAndEndsStreams) {
  Link link;
  ASSERT_TRUE(link.ready());
  link.peer->deaf(true);
  std::promise<tether::rpc::error_code> call_done;
  link.client->async_call("MoveJoint", *link.move_request(1, 1),
                          [&](tether::rpc::error_code e, CallResult) { call_done.set_value(e); });
  std::promise<tether::rpc::error_code> stream_end;
  tether::rpc::Stream watch = link.client->open_stream(
      "Watch", *link.client->new_request("Watch"), 100ms,
      [&](const tether::rpc::error_code& error, const tether::rpc::StreamMessage&) {
        if (error) stream_end.set_value(error);
      });
  link.run_for(5);
  link.client->close();
  EXPECT_EQ(call_done.get_future().get(), boost::asio::error::operation_aborted);
  EXPECT_EQ(stream_end.get_future().get(), boost::asio::error::operation_aborted);
}

}  // namespace
