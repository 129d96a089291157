// Client against a scripted fake device over an in-memory pair: the reference vectors, answers and
// errors, host-side validation, retries, stale frames (B4), invalid JSON (B5), long lines (B2), log lines,
// the timing rules, id wrap, concurrency, close, damaged answers (B3) and manual mode.
#include <gtest/gtest.h>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/asio/use_future.hpp>

#include <atomic>
#include <future>
#include <mutex>
#include <thread>

#include "tether/testing/child_process.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "test_support.hpp"

namespace tether::romi::testing {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
namespace asio = boost::asio;
using IoThread = ::tether::transports::IoThread;

// Generous bound for "completes promptly" (no timing assertion tighter than this, ASan included).
constexpr auto kPrompt = 10000ms;  // "promptly": a bound against hangs, never a timing assertion

// --- reference vectors ------------------------------------------------------------------------------------

TEST(RomiClient, FirstRequestsFromId255AreTheReferenceFrames) {
  IoThread io;
  {
    Link link(io.executor());
    link.device->on_request(answer_with("[0]"));
    const RomiResponse response = link.client->call("a");
    EXPECT_TRUE(response.ok());
    EXPECT_EQ(link.device->received(), "#a:008e\r\n");
  }
  {
    Link link(io.executor());
    link.device->on_request(answer_with("[0]"));
    link.client->call("a[1,2,3]");
    EXPECT_EQ(link.device->received(), "#a[1,2,3]:00dd\r\n");
  }
  {
    Link link(io.executor());
    link.device->on_request(answer_with("[0]"));
    link.client->call('a', {1, 2, 3});  // built: the same bytes
    EXPECT_EQ(link.device->received(), "#a[1,2,3]:00dd\r\n");
  }
}

TEST(RomiClient, PublishedResponseVectorsAreRead) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    // The spec's firmware answers, sent verbatim (ids 00 as in the vectors; the client's first id is 0).
    if (request.payload == "e") device.send("#e[0,1,2]:00dc\r\n");
  });
  const RomiResponse response = link.client->call("e");
  EXPECT_EQ(response.values, json::parse("[0,1,2]"));
  EXPECT_EQ(response.raw, "e[0,1,2]");
  EXPECT_EQ(response.opcode, 'e');
  EXPECT_EQ(response.id, 0);
  EXPECT_TRUE(response.answered);
}

// --- answers ----------------------------------------------------------------------------------------------

TEST(RomiClient, SuccessCarriesTheWholeArray) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with(R"([0,512,-3,"text",1.5])"));
  error_code error;
  const RomiResponse response = link.client->call("A", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.code, 0);
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.values, json::parse(R"([0,512,-3,"text",1.5])"));
  EXPECT_EQ(response.message, "");
  EXPECT_EQ(response.attempts, 1);
}

TEST(RomiClient, ApplicationErrorIsAnAnswerNotAnErrorCode) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response('f', R"([101,"I will try again tomorrow"])", request.id));
  });
  error_code error;
  RomiResponse response = link.client->call("f", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.code, 101);
  EXPECT_TRUE(response.application_error());
  EXPECT_EQ(response.message, "I will try again tomorrow");
  EXPECT_EQ(response.values, json::parse(R"([101,"I will try again tomorrow"])"));
  EXPECT_NO_THROW(response = link.client->call("f"));  // the throwing form returns answers
  EXPECT_EQ(response.code, 101);
}

TEST(RomiClient, DeviceProtocolErrorWithoutMessageGetsTheTableText) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[-17]"));
  error_code error;
  const RomiResponse response = link.client->call("a[1]", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.code, -17);
  EXPECT_EQ(response.message, "bad number of arguments");
}

// --- rejected before the wire -----------------------------------------------------------------------------

TEST(RomiClient, InvalidCommandsNeverReachTheWire) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[0]"));
  const std::string long_string(33, 'x');
  const std::vector<std::int32_t> thirteen(13, 1);
  const std::vector<std::int32_t> twelve_wide(12, -32768);  // 12 x 7 characters: frame over 64 bytes
  const struct {
    Command command;
    Error expected;
  } cases[] = {
      {Command(""), Error::client_empty_request},
      {Command("~"), Error::invalid_opcode},
      {Command('#'), Error::invalid_opcode},
      {Command("a[1,2,3,4,5,6,7,8,9,10,11,12,13]"), Error::too_many_arguments},
      {Command('a', thirteen), Error::too_many_arguments},
      {Command("a[40000]"), Error::value_out_of_range},
      {Command('a', {-32769}), Error::value_out_of_range},
      {Command("a[\"" + long_string + "\"]"), Error::string_too_long},
      {Command('a', {}, long_string), Error::string_too_long},
      {Command("a[\"<>\"]"), Error::invalid_string},
      {Command('a', {}, "tab\there"), Error::invalid_string},
      {Command("a[\"x\",\"y\"]"), Error::too_many_strings},
      {Command('a', twelve_wide), Error::client_request_too_long},
      {Command("a[-32768,-32768,-32768,-32768,-32768,-32768,-32768,-32768,-32768]"),
       Error::client_request_too_long},
      {Command('M', {16}, "a:b"), Error::reserved_character},
      {Command('M', {}, "say \"hi\""), Error::reserved_character},
      {Command("a[\"#\"]"), Error::reserved_character},
      {Command("a:1"), Error::reserved_character},
      {Command("a[1"), Error::unexpected_char},
  };
  for (const auto& test : cases) {
    SCOPED_TRACE(test.command.payload());
    EXPECT_FALSE(test.command.valid());
    EXPECT_EQ(test.command.error(), test.expected);
    error_code error;
    const RomiResponse response = link.client->call(test.command, error);
    EXPECT_EQ(error, test.expected);
    EXPECT_EQ(error.category(), romi_category());
    EXPECT_EQ(response.code, static_cast<std::int16_t>(test.expected));
    // The table's text, and for a raw command where it goes wrong.
    EXPECT_EQ(response.values, json::array({response.code, test.command.error_text()}));
    EXPECT_EQ(test.command.error_text().rfind(romi::describe(response.code), 0), 0u);
    EXPECT_FALSE(response.answered);
    EXPECT_EQ(response.attempts, 0);
    EXPECT_FALSE(response.unreadable_answer());
    // What a tool reports for it without opening a device (`tether call`) is the call's response.
    const RomiResponse rejected = failed_response(test.command);
    EXPECT_EQ(rejected.code, response.code);
    EXPECT_EQ(rejected.values, response.values);
    EXPECT_EQ(rejected.message, response.message);
    EXPECT_EQ(rejected.opcode, response.opcode);
    EXPECT_EQ(rejected.id, response.id);
    EXPECT_EQ(rejected.attempts, response.attempts);
    EXPECT_EQ(rejected.answered, response.answered);
    EXPECT_EQ(rejected.raw, response.raw);
    EXPECT_THROW(link.client->call(test.command), boost::system::system_error);
  }
  // Nothing was written, and no id was used: the first valid call is the reference's first frame.
  const RomiResponse response = link.client->call("a");
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(link.device->received(), "#a:008e\r\n");
}

// An invalid raw command says where it goes wrong; the call completes with that text.
TEST(RomiClient, InvalidCommandTextSaysWhere) {
  EXPECT_EQ(Command("e[0,,1]").error_text(), "unexpected char at character 5 (',')");
  EXPECT_EQ(Command(std::string_view("e[\x01]", 4)).error_text(), "unexpected char at character 3 (\\x01)");
  EXPECT_EQ(Command("e[0").error_text(), "unexpected char at the end (the command is incomplete)");
  EXPECT_FALSE(Command("").error_offset().has_value());
  EXPECT_FALSE(Command('a', {-32769}).error_offset().has_value());
  EXPECT_EQ(Command("e[1]").error_text(), "");
  IoThread io;
  Link link(io.executor());
  error_code error;
  const RomiResponse response = link.client->call(Command("e[0,,1]"), error);
  EXPECT_EQ(error, make_error_code(Error::unexpected_char));
  EXPECT_EQ(response.message, "unexpected char at character 5 (',')");
  EXPECT_EQ(link.device->received(), "");
}

TEST(RomiClient, BuiltCommandsAreTheExpectedPayloads) {
  EXPECT_EQ(Command('M', {16}, "Shutdown").payload(), "M[16,\"Shutdown\"]");
  EXPECT_EQ(Command('a').payload(), "a");
  EXPECT_EQ(Command('c', {-32768, 32767}).payload(), "c[-32768,32767]");
  EXPECT_EQ(Command('d', {}, "").payload(), "d[\"\"]");
  EXPECT_EQ(Command('?').payload(), "?");
  // The longest accepted frame is 64 bytes: a 56-character payload.
  const std::string longest = "a[\"" + std::string(32, 'x') + "\",1000,1000,1000,100]";
  ASSERT_EQ(longest.size(), kMaxHostPayload);
  EXPECT_TRUE(Command(longest).valid());
  EXPECT_EQ(request_frame(longest, 0).size(), kMaxRequestFrame);
  const std::string too_long = "a[\"" + std::string(32, 'x') + "\",1000,1000,1000,1000]";  // 57
  EXPECT_EQ(Command(too_long).error(), Error::client_request_too_long);
}

// --- retries ----------------------------------------------------------------------------------------------

TEST(RomiClient, EnvelopeErrorAnswerIsRetriedWithTheSameBytes) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, request.repeat == 1 ? "[-4]" : "[0,7]", request.id));
  });
  const RomiResponse response = link.client->call("b[5]");
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.values, json::parse("[0,7]"));
  EXPECT_EQ(response.attempts, 2);
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[0].frame, request_frame("b[5]", 0));
  EXPECT_EQ(requests[1].frame, requests[0].frame);
  EXPECT_EQ(link.client->counters().link.retries, 1u);
}

TEST(RomiClient, EveryEnvelopeErrorCodeIsRetriedAndOthersAreNot) {
  IoThread io;
  Link link(io.executor());
  std::atomic<int> code{0};
  link.device->on_request([&code](const DeviceRequest& request, FakeDevice& device) {
    const std::string body = request.repeat == 1 ? "[" + std::to_string(code.load()) + "]" : "[0]";
    device.send(FakeDevice::response(request.opcode, body, request.id));
  });
  for (int c = -20; c <= -1; ++c) {
    SCOPED_TRACE(c);
    code = c;
    const std::size_t before = link.device->requests().size();
    const RomiResponse response = link.client->call("a");
    const std::size_t sent = link.device->requests().size() - before;
    if (c >= -6) {
      EXPECT_TRUE(response.ok());
      EXPECT_EQ(sent, 2u);
    } else {
      EXPECT_EQ(response.code, c);  // e.g. -16: delivered at once, no second send
      EXPECT_EQ(response.attempts, 1);
      EXPECT_EQ(sent, 1u);
    }
  }
}

TEST(RomiClient, UnknownOpcodeIsNotRetried) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[-16]"));
  error_code error;
  const RomiResponse response = link.client->call("z", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.code, -16);
  EXPECT_EQ(response.message, "unknown opcode");
  EXPECT_EQ(link.device->requests().size(), 1u);
  EXPECT_EQ(link.client->counters().link.retries, 0u);
}

TEST(RomiClient, EnvelopeErrorsStopAfterThreeSends) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[-4]"));
  error_code error;
  const RomiResponse response = link.client->call("a", error);
  EXPECT_FALSE(error);  // the device answered, three times
  EXPECT_EQ(response.code, -4);
  EXPECT_EQ(response.attempts, 3);
  EXPECT_EQ(link.device->requests().size(), 3u);
}

// --- stale frames (B4) ------------------------------------------------------------------------------------

TEST(RomiClient, StaleAnswerIsIgnoredAndTheRightOneDelivered) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, "[0,111]", static_cast<std::uint8_t>(request.id - 1)));
    device.send(FakeDevice::response(request.opcode, "[0,222]", request.id));
  });
  const RomiResponse response = link.client->call("a");
  EXPECT_EQ(response.values, json::parse("[0,222]"));
  EXPECT_EQ(link.client->counters().link.stale, 1u);
}

TEST(RomiClient, ErrorFrameWithAnotherIdIsNotPinnedOnTheCall) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    const auto other = static_cast<std::uint8_t>(request.id + 7);
    device.send(FakeDevice::response(request.opcode, "[-16]", other));  // not retried, not delivered
    device.send(FakeDevice::response(request.opcode, "[101,\"late\"]", other));
    device.send(FakeDevice::response(request.opcode, "[0]", request.id));
  });
  const RomiResponse response = link.client->call("a");
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.attempts, 1);
  EXPECT_EQ(link.device->requests().size(), 1u);
  EXPECT_EQ(link.client->counters().link.stale, 2u);
}

// The device could not read the request's id (`#a:5o8e` for `#a:508e`), so it answered its envelope error
// with id 00: it executed nothing, and the same bytes go again (the reference host does this too).
TEST(RomiClient, EnvelopeErrorUnderAnotherIdSendsTheSameBytesAgain) {
  IoThread io;
  Options options = short_timing(400, 2000);
  Link link(io.executor(), options.first_id(0x50));
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    if (request.repeat == 1) {
      device.send(FakeDevice::response('_', "[-2]", 0));
    } else {
      device.send(FakeDevice::response(request.opcode, "[0,7]", request.id));
    }
  });
  error_code error;
  const RomiResponse response = link.client->call("a", error);
  EXPECT_FALSE(error) << error.message();
  EXPECT_EQ(response.values, json::parse("[0,7]"));
  EXPECT_EQ(response.id, 0x50);
  EXPECT_EQ(response.attempts, 2);
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[1].frame, requests[0].frame);
  EXPECT_EQ(link.client->counters().link.retries, 1u);
  EXPECT_EQ(link.client->counters().link.stale, 0u);
}

// ... but only the call's own answer completes it: when every send gets an envelope error under another
// id, the call times out (no answer), the errors are not delivered as the device's answer.
TEST(RomiClient, EnvelopeErrorsUnderAnotherIdNeverCompleteTheCall) {
  IoThread io;
  Options options = short_timing(200, 5000);
  Link link(io.executor(), options.first_id(0x50));
  link.device->on_request([](const DeviceRequest&, FakeDevice& device) {
    device.send(FakeDevice::response('_', "[-4]", 0x33));
  });
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a");
  // The three sends and their errors take no simulated time; the third send's window then ends the call.
  ASSERT_TRUE(link.device->wait_for_requests(3, kPrompt));
  ASSERT_TRUE(::tether::testing::eventually([&] { return link.client->counters().link.stale == 1; }, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->advance_to_due(static_cast<Millis>(start + 200), due)) << "+" << due - start;
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);
  const auto [error, response] = outcome.get();
  EXPECT_EQ(error, Error::client_timeout);
  EXPECT_FALSE(response.answered);
  EXPECT_EQ(response.attempts, 3);
  EXPECT_EQ(link.device->requests().size(), 3u);
  EXPECT_EQ(link.client->counters().link.stale, 1u);  // the third send's error: no sends left
}

TEST(RomiClient, LateErrorOfATimedOutCallIsNotPinnedOnTheNextCall) {
  IoThread io;
  Link link(io.executor(), short_timing(150, 300));
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    if (request.id == 0) return;  // the first call gets no answer in time
    // The first call's late error arrives just before the second call's own answer.
    device.send(FakeDevice::response('a', R"([-16,"late"])", 0));
    device.send(FakeDevice::response(request.opcode, "[0,2]", request.id));
  });
  const Millis start = link.clock->now();
  auto first = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->advance_to_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  ASSERT_EQ(first.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(first.get().error, Error::client_timeout);
  error_code error;
  const RomiResponse second = link.client->call("b", error);  // the clock stands still: it cannot time out
  EXPECT_FALSE(error);
  EXPECT_EQ(second.values, json::parse("[0,2]"));
  EXPECT_EQ(second.id, 1);
  EXPECT_EQ(link.client->counters().link.stale, 1u);
}

TEST(RomiClient, SuccessWithTheRightIdButAnotherOpcodeIsStale) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response('x', "[0,1]", request.id));
    device.send(FakeDevice::response(request.opcode, "[0,2]", request.id));
  });
  const RomiResponse response = link.client->call("a");
  EXPECT_EQ(response.values, json::parse("[0,2]"));
  EXPECT_EQ(link.client->counters().link.stale, 1u);
}

// --- unreadable answers (B5) ------------------------------------------------------------------------------

TEST(RomiClient, InvalidJsonIsCodeMinus26AndNeverThrows) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[0,oops]"));
  error_code error;
  RomiResponse response = link.client->call("a", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.code, -26);
  EXPECT_EQ(response.message, "client: invalid JSON");
  EXPECT_EQ(response.values, json::array({-26, "client: invalid JSON"}));
  EXPECT_EQ(response.raw, "a[0,oops]");
  EXPECT_TRUE(response.answered);
  EXPECT_TRUE(response.unreadable_answer());  // what arrived is worth showing
  EXPECT_NO_THROW(response = link.client->call("a"));
  EXPECT_EQ(response.code, -26);
  EXPECT_EQ(link.device->requests().size(), 2u);  // -26 is not retried
}

TEST(RomiClient, AnswersThatAreNotACodeArrayAreBadlyFormed) {
  IoThread io;
  Link link(io.executor());
  std::atomic<int> which{0};
  const char* bodies[] = {R"("text")", "[]", R"(["0"])", "[40000]", "[1.5]", ""};
  link.device->on_request([&](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, bodies[which.load()], request.id));
  });
  for (int i = 0; i < 6; ++i) {
    SCOPED_TRACE(bodies[i]);
    which = i;
    error_code error;
    const RomiResponse response = link.client->call("a", error);
    EXPECT_FALSE(error);
    EXPECT_EQ(response.code, i == 5 ? -23 : -27);
    EXPECT_EQ(response.raw, std::string("a") + bodies[i]);
    EXPECT_TRUE(response.unreadable_answer());
  }
}

// --- long lines (B2) and log lines ------------------------------------------------------------------------

TEST(RomiClient, LongAnswersAndLogLinesAreRead) {
  IoThread io;
  Link link(io.executor());
  const std::string long_log = "log line with colons: " + std::string(300, 'L') + ": end";
  const std::string long_value(200, 'v');
  std::mutex mutex;
  std::vector<std::string> logs;
  link.client->on_event(on_log([&](std::string_view text) {
    std::lock_guard lock(mutex);
    logs.emplace_back(text);
  }));
  link.device->on_request([&](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::log(long_log));
    device.send(FakeDevice::response(request.opcode, "[0,\"" + long_value + "\",12345]", request.id));
  });
  const RomiResponse response = link.client->call("a");
  ASSERT_TRUE(response.ok());
  EXPECT_EQ(response.values[1], long_value);
  std::lock_guard lock(mutex);
  ASSERT_EQ(logs.size(), 1u);
  EXPECT_EQ(logs[0], long_log);
}

TEST(RomiClient, LogLinesBetweenRequestAndAnswerReArmTheAttemptWindow) {
  IoThread io;
  // Six log lines 300 ms apart, then the answer: 1950 ms after the request, twice the attempt window.
  Link link(io.executor(), short_timing(1000, 5000));
  std::mutex mutex;
  std::vector<std::string> logs;
  link.client->on_event(on_log([&](std::string_view text) {
    std::lock_guard lock(mutex);
    logs.emplace_back(text);
  }));
  const auto log_count = [&] {
    std::lock_guard lock(mutex);
    return logs.size();
  };
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + 1000), due)) << "+" << due - start;
  for (std::size_t step = 1; step <= 6; ++step) {
    link.clock->advance(300);
    link.device->send(FakeDevice::log("step " + std::to_string(step)));
    ASSERT_TRUE(::tether::testing::eventually([&] { return log_count() == step; }, kPrompt));
    // The line re-armed the window: due 1000 ms after it, not after the request.
    ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + 300 * step + 1000), due))
        << step << ": +" << due - start;
  }
  link.clock->advance(150);  // 1950 ms: past the first window, inside the re-armed one
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 1u);
  link.device->send(FakeDevice::response(requests[0].opcode, "[0]", requests[0].id));
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);
  const auto [error, response] = outcome.get();
  EXPECT_FALSE(error) << error.message();
  EXPECT_TRUE(response.ok());
  std::lock_guard lock(mutex);
  EXPECT_EQ(logs, (std::vector<std::string>{"step 1", "step 2", "step 3", "step 4", "step 5", "step 6"}));
}

TEST(RomiClient, LogLinesBetweenCallsGoToTheSink) {
  IoThread io;
  Link link(io.executor());
  std::promise<std::string> got;
  link.client->on_event(on_log([&](std::string_view text) { got.set_value(std::string(text)); }));
  link.device->send(FakeDevice::log("booted: v1.2"));
  auto future = got.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(future.get(), "booted: v1.2");
}

TEST(RomiClient, BlockingCallFromTheLogHandlerFailsInsteadOfDeadlocking) {
  IoThread io;
  Link link(io.executor());
  std::promise<error_code> inner;
  Client& client = *link.client;
  const EventHandlerId id = client.on_event(on_log([&](std::string_view) {
    error_code error;
    client.call("a", error);  // would wait for the strand it runs on
    inner.set_value(error);
  }));
  link.device->send(FakeDevice::log("hello"));
  auto future = inner.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(future.get(), transports::make_error_code(transports::TransportError::would_deadlock));
  client.remove_event_handler(id);
}

// --- timing -----------------------------------------------------------------------------------------------

// Every Link runs on a manual clock: deadlines pass only when a test advances it, so the tests below assert
// on simulated time and a loaded machine cannot move a deadline.

TEST(RomiClient, LogLinesNeverStretchACallPastItsBudget) {
  IoThread io;
  // The spec's case scaled by 4: attempt 250 ms, budget 500 ms, a log line every 200 ms, never an answer.
  std::atomic<int> logs{0};
  Link link(io.executor(), short_timing(250, 500));
  link.client->on_event(on_log([&](std::string_view) { ++logs; }));
  const Millis start = link.clock->now();
  auto future = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + 250), due)) << "+" << due - start;
  // At 200 and 400 ms a log line re-arms the 250 ms window: due at 450 ms, then the budget's 500 ms first.
  const Millis earliest[] = {450, 500};
  for (int step = 1; step <= 2; ++step) {
    link.clock->advance(200);
    link.device->send(FakeDevice::log("busy"));
    ASSERT_TRUE(::tether::testing::eventually([&] { return logs.load() == step; }, kPrompt));
    ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + earliest[step - 1]), due))
        << step << ": +" << due - start;
  }
  link.clock->advance(99);  // 499 ms: the window (re-armed at 400 ms) and the budget still run
  EXPECT_NE(future.wait_for(20ms), std::future_status::ready);
  link.clock->advance(1);  // 500 ms: the budget ends, not 400 + 250
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  const Outcome outcome = future.get();
  EXPECT_EQ(outcome.error, Error::client_timeout);
  EXPECT_EQ(outcome.error, boost::system::errc::timed_out);
  EXPECT_EQ(outcome.response.code, -25);
  EXPECT_EQ(outcome.response.message, "client: no reply from the device within 500 ms");
  EXPECT_EQ(link.client->counters().link.timeouts, 1u);
  EXPECT_EQ(link.device->requests().size(), 1u);  // a silent attempt is not re-sent
}

TEST(RomiClient, SilentDeviceTimesOutAfterTheAttemptWindow) {
  IoThread io;
  Link link(io.executor(), short_timing(150, 5000));
  const Millis start = link.clock->now();
  auto future = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  link.clock->advance(149);
  EXPECT_NE(future.wait_for(20ms), std::future_status::ready);
  link.clock->advance(1);  // the attempt window, far from the 5 s budget
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  const Outcome outcome = future.get();
  EXPECT_EQ(outcome.error, Error::client_timeout);
  EXPECT_FALSE(outcome.response.answered);
  EXPECT_EQ(outcome.response.attempts, 1);
  EXPECT_EQ(outcome.response.message, "client: no reply from the device within 150 ms");
  EXPECT_EQ(link.device->requests().size(), 1u);
}

// --- cancellation -------------------------------------------------------------------------------------------

TEST(RomiClient, CancellingOneCallLeavesTheOthersAlone) {
  IoThread io;
  std::promise<Outcome> first, second, third;  // before the link: completions at its close find them
  client::CancellationSignal cancel_second, cancel_first;
  Link link(io.executor(), short_timing(250, 500));
  link.client->async_call("a", client::bind_cancellation(cancel_first, [&](error_code e, RomiResponse r) {
                            first.set_value({e, std::move(r)});
                          }));
  link.client->async_call("b", client::bind_cancellation(cancel_second, [&](error_code e, RomiResponse r) {
                            second.set_value({e, std::move(r)});
                          }));
  link.client->async_call("c", [&](error_code e, RomiResponse r) { third.set_value({e, std::move(r)}); });
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  cancel_second.emit();  // queued: never reaches the wire
  auto second_done = second.get_future();
  ASSERT_EQ(second_done.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(second_done.get().error, boost::asio::error::operation_aborted);
  cancel_first.emit();  // in flight: completes at once, without waiting for its 250 ms window
  auto first_done = first.get_future();
  ASSERT_EQ(first_done.wait_for(kPrompt), std::future_status::ready);
  const Outcome aborted = first_done.get();
  EXPECT_EQ(aborted.error, boost::asio::error::operation_aborted);
  EXPECT_EQ(aborted.response.code, -33);
  // The third call goes next; its answer completes it.
  ASSERT_TRUE(link.device->wait_for_requests(2, kPrompt));
  const auto requests = link.device->requests();
  EXPECT_EQ(requests[1].opcode, 'c');
  link.device->send(FakeDevice::response('c', "[0]", requests[1].id));
  auto third_done = third.get_future();
  ASSERT_EQ(third_done.wait_for(kPrompt), std::future_status::ready);
  EXPECT_FALSE(third_done.get().error);
  cancel_first.emit();  // after completion: nothing to cancel
  EXPECT_TRUE(link.client->is_open());
}

TEST(RomiClient, TimeoutSaysHowLongTheCallWaitedForAnAnswer) {
  IoThread io;
  Link link(io.executor(), short_timing(150, 5000));
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->wait_for_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  link.clock->advance(400);  // the timer fires 250 ms after its deadline
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);
  const auto [error, response] = outcome.get();
  EXPECT_EQ(error, Error::client_timeout);
  EXPECT_EQ(error.message(), "client: no reply from the device");
  EXPECT_EQ(response.code, -25);
  // The deadline that ended the call, from the first send: exact however late the timer fired.
  EXPECT_EQ(response.message, "client: no reply from the device within 150 ms");
  EXPECT_EQ(response.values, json::array({-25, response.message}));
}

TEST(RomiClient, SilentAttemptIsSentAgainWhenRetryOnTimeoutIsSet) {
  IoThread io;
  Options options = short_timing(150, 3000);
  options.timing.retry_on_timeout = true;
  Link link(io.executor(), options);
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    if (request.repeat > 1) device.send(FakeDevice::response(request.opcode, "[0]", request.id));  // 1st lost
  });
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a");
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->advance_to_due(static_cast<Millis>(start + 150), due)) << "+" << due - start;
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);  // sent again at 150 ms, answered
  const auto [error, response] = outcome.get();
  EXPECT_FALSE(error) << error.message();
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.attempts, 2);
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[1].frame, requests[0].frame);  // same id: Tether firmware answers it from its cache
  EXPECT_EQ(link.client->counters().link.timeouts, 0u);
}

TEST(RomiClient, SilentDeviceWithRetryOnTimeoutStopsAtTheBudget) {
  IoThread io;
  Options options = short_timing(150, 400);
  options.timing.retry_on_timeout = true;
  Link link(io.executor(), options);
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a");
  // Sends at 0, 150 and 300 ms; the third window (to 450 ms) is cut at the 400 ms budget.
  const Millis deadlines[] = {150, 300, 400};
  for (std::size_t send = 1; send <= 3; ++send) {
    ASSERT_TRUE(link.device->wait_for_requests(send, kPrompt)) << send;
    Millis due = 0;
    ASSERT_TRUE(link.clock->advance_to_due(static_cast<Millis>(start + deadlines[send - 1]), due))
        << send << ": +" << due - start;
  }
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);
  const auto [error, response] = outcome.get();
  EXPECT_EQ(error, Error::client_timeout);
  EXPECT_EQ(response.attempts, 3);
  EXPECT_EQ(response.message, "client: no reply from the device within 400 ms (3 sends)");
  EXPECT_EQ(link.device->requests().size(), 3u);
}

TEST(RomiClient, DefaultTimingIsTheSpecs) {
  const Options options;
  EXPECT_EQ(options.timing.attempt_timeout, 1000u);
  EXPECT_EQ(options.timing.call_budget, 2000u);
  EXPECT_EQ(options.timing.max_attempts, 3);
  EXPECT_FALSE(options.timing.retry_on_timeout);
  EXPECT_TRUE(options.timing.activity_rearms_attempt);
  EXPECT_EQ(options.last_id, 255);
}

// --- ids, concurrency, many devices -----------------------------------------------------------------------

TEST(RomiClient, IdsWrapAfter255) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, "[0," + std::to_string(request.id) + "]", request.id));
  });
  for (int i = 0; i < 300; ++i) {
    const RomiResponse response = link.client->call("a");
    ASSERT_TRUE(response.ok()) << i;
    ASSERT_EQ(response.id, i % 256);
    ASSERT_EQ(response.values[1], i % 256);
  }
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 300u);
  EXPECT_EQ(requests[255].id, 255);
  EXPECT_EQ(requests[256].id, 0);
  EXPECT_EQ(link.client->counters().link.stale, 0u);
}

TEST(RomiClient, FirstIdIsTheOneChosen) {
  IoThread io;
  Options options = short_timing();
  Link link(io.executor(), options.first_id(0));  // 0 wraps: last_id 255
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, "[0]", request.id));
  });
  EXPECT_EQ(link.client->call("a").id, 0);
  const std::uint8_t random = random_first_id();
  EXPECT_LE(random, 254);  // never 255 (defect B6)
  Options seven = short_timing();
  Link other(io.executor(), seven.first_id(7));
  other.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::response(request.opcode, "[0]", request.id));
  });
  EXPECT_EQ(other.client->call("a").id, 7);
  EXPECT_EQ(other.client->call("a").id, 8);
}

// Echo device: `c[t,i]` is answered `[0,t,i]`.
void echo_arguments(const DeviceRequest& request, FakeDevice& device) {
  if (request.error != Error::no_error) return;
  const std::string arguments = request.payload.size() > 2 ? request.payload.substr(2) : "]";
  device.send(FakeDevice::response(request.opcode, "[0," + arguments, request.id));
}

TEST(RomiClient, ConcurrentCallsFromSeveralThreadsGetTheirOwnAnswers) {
  IoThread io(3);
  Link link(io.executor());
  link.device->on_request(echo_arguments);
  constexpr int kThreads = 4;
  constexpr int kCalls = 40;
  std::atomic<int> wrong{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kCalls; ++i) {
        error_code error;
        const RomiResponse response = link.client->call({'c', {t, i}}, error);
        if (error || response.values != json::array({0, t, i})) ++wrong;
      }
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_EQ(link.device->requests().size(), static_cast<std::size_t>(kThreads * kCalls));
  EXPECT_EQ(link.client->counters().link.frames_ok, static_cast<std::uint32_t>(kThreads * kCalls));
}

TEST(RomiClient, QueuedAsyncCallsCompleteInOrder) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(echo_arguments);
  std::vector<std::future<RomiResponse>> futures;
  for (int i = 0; i < 20; ++i) futures.push_back(link.client->async_call({'c', {i}}, asio::use_future));
  for (int i = 0; i < 20; ++i) {
    ASSERT_EQ(futures[static_cast<std::size_t>(i)].wait_for(kPrompt), std::future_status::ready);
    const RomiResponse response = futures[static_cast<std::size_t>(i)].get();
    EXPECT_EQ(response.values, json::array({0, i}));
    EXPECT_EQ(response.id, i);  // started in submission order
  }
}

TEST(RomiClient, ManyDevicesShareOneIoContext) {
  IoThread io(2);
  std::vector<std::unique_ptr<Link>> links;
  for (int d = 0; d < 4; ++d) {
    links.push_back(std::make_unique<Link>(io.executor()));
    links.back()->device->on_request([d](const DeviceRequest& request, FakeDevice& device) {
      device.send(FakeDevice::response(request.opcode, "[0," + std::to_string(d) + "]", request.id));
    });
  }
  std::vector<std::pair<int, std::future<RomiResponse>>> futures;
  for (int round = 0; round < 10; ++round) {
    for (int d = 0; d < 4; ++d) {
      futures.emplace_back(d, links[static_cast<std::size_t>(d)]->client->async_call("v", asio::use_future));
    }
  }
  for (auto& [d, future] : futures) {
    ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
    EXPECT_EQ(future.get().values, json::array({0, d}));
  }
}

// --- completion tokens ------------------------------------------------------------------------------------

TEST(RomiClient, CallbackRunsOutsideTheInitiationWithTheAnswer) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[0,1]"));
  // Initiated on the io thread itself: a completion inside the initiation would run before `returned`.
  std::promise<std::pair<error_code, RomiResponse>> answered;
  std::promise<bool> rejected_after_return;
  bool returned = false;  // touched on the io thread only
  asio::post(io.executor(), [&] {
    link.client->async_call("", [&](error_code, RomiResponse) { rejected_after_return.set_value(returned); });
    link.client->async_call("a", [&](error_code error, RomiResponse response) {
      answered.set_value({error, std::move(response)});
    });
    returned = true;
  });
  auto rejected = rejected_after_return.get_future();
  ASSERT_EQ(rejected.wait_for(kPrompt), std::future_status::ready);
  EXPECT_TRUE(rejected.get());  // even an immediate rejection is posted
  auto future = answered.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  const auto [error, response] = future.get();
  EXPECT_FALSE(error);
  EXPECT_EQ(response.values, json::parse("[0,1]"));
}

TEST(RomiClient, FutureThrowsOnlyWhenThereIsNoAnswer) {
  IoThread io;
  Link link(io.executor());
  auto rejected = link.client->async_call("a[99999]", asio::use_future);
  try {
    rejected.get();
    ADD_FAILURE() << "expected an exception";
  } catch (const boost::system::system_error& failure) {
    EXPECT_EQ(failure.code(), Error::value_out_of_range);
  }
  link.device->on_request(answer_with("[5]"));
  EXPECT_EQ(link.client->async_call("a", asio::use_future).get().code, 5);
}

#if defined(BOOST_ASIO_HAS_CO_AWAIT)
TEST(RomiClient, WorksInACoroutine) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(echo_arguments);
  std::promise<std::vector<json>> done;
  Client& client = *link.client;
  asio::co_spawn(
      io.executor(),
      [&]() -> asio::awaitable<void> {
        std::vector<json> values;
        // Commands are named values: g++ 12 rejects braced lists and literals inside co_await expressions.
        for (int i = 0; i < 3; ++i) {
          const Command command('c', std::vector<std::int32_t>{i});
          values.push_back((co_await client.async_call(command, asio::use_awaitable)).values);
        }
        try {
          const Command empty("");
          co_await client.async_call(empty, asio::use_awaitable);
        } catch (const boost::system::system_error& failure) {
          values.push_back(failure.code().value());
        }
        done.set_value(values);
      },
      asio::detached);
  auto future = done.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(future.get(), (std::vector<json>{json::array({0, 0}), json::array({0, 1}), json::array({0, 2}), -24}));
}
#endif

// --- close and link failures ------------------------------------------------------------------------------

TEST(RomiClient, CloseAbortsTheCallInFlightAndTheQueuedOnes) {
  IoThread io;
  Link link(io.executor(), short_timing(60000, 60000));  // a silent device and no timeout in sight
  std::vector<std::future<RomiResponse>> futures;
  for (int i = 0; i < 3; ++i) futures.push_back(link.client->async_call("a", asio::use_future));
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  link.client->close();
  EXPECT_FALSE(link.client->is_open());
  for (auto& future : futures) {
    ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
    try {
      future.get();
      ADD_FAILURE() << "expected operation_aborted";
    } catch (const boost::system::system_error& failure) {
      EXPECT_EQ(failure.code(), asio::error::operation_aborted);
    }
  }
  error_code error;
  const RomiResponse late = link.client->call("a", error);
  EXPECT_EQ(error, asio::error::operation_aborted);
  EXPECT_EQ(late.code, -33);
  EXPECT_EQ(link.device->requests().size(), 1u);  // queued calls never reached the wire
}

TEST(RomiClient, DestroyingTheClientAbortsItsCalls) {
  IoThread io;
  auto [host_end, device_end] = transports::InMemoryStream::make_pair(io.executor());
  auto device = FakeDevice::start(device_end);
  std::promise<error_code> done;
  {
    Client client(host_end, short_timing(60000, 60000));
    client.async_call("a", [&](error_code error, RomiResponse) { done.set_value(error); });
    ASSERT_TRUE(device->wait_for_requests(1, kPrompt));
  }
  auto future = done.get_future();
  ASSERT_EQ(future.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(future.get(), asio::error::operation_aborted);
  device->close();
}

TEST(RomiClient, VanishedDeviceFailsTheCallWithTheTransportError) {
  IoThread io;
  Link link(io.executor(), short_timing(60000, 60000));
  link.device->on_request([](const DeviceRequest&, FakeDevice& device) { device.close(); });
  error_code error;
  RomiResponse response = link.client->call("a", error);
  EXPECT_EQ(error, asio::error::eof);
  EXPECT_EQ(response.code, -33);
  EXPECT_NE(response.message.find("transport error"), std::string::npos);
  response = link.client->call("a", error);  // the link stays failed: at once, no 60 s wait
  EXPECT_EQ(error, asio::error::eof);
}

TEST(RomiClient, AnIdleClientHearsOfTheLinkFailureOnce) {
  IoThread io;
  Link link(io.executor(), short_timing(60000, 60000));
  std::mutex mutex;
  std::vector<error_code> failures;
  std::promise<void> first;
  link.client->on_event(on_link_failed([&](error_code error) {
    std::lock_guard lock(mutex);
    failures.push_back(error);
    if (failures.size() == 1) first.set_value();
  }));
  link.device->close();  // no call in flight: only the handler can tell the application
  ASSERT_EQ(first.get_future().wait_for(kPrompt), std::future_status::ready);
  error_code error;
  link.client->call("a", error);  // fails at once with the same error, and does not report again
  EXPECT_EQ(error, asio::error::eof);
  link.client->close();
  std::lock_guard lock(mutex);
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0], asio::error::eof);
}

TEST(RomiClient, CloseIsNotALinkFailure) {
  IoThread io;
  Link link(io.executor(), short_timing(60000, 60000));
  std::atomic<int> calls{0};
  link.client->on_event(on_link_failed([&](error_code) { ++calls; }));
  link.client->close();
  error_code error;
  link.client->call("a", error);
  EXPECT_EQ(error, asio::error::operation_aborted);
  EXPECT_EQ(calls.load(), 0);
}

// --- damaged answers (B3) ---------------------------------------------------------------------------------

TEST(RomiClient, DamagedAnswerIsReSentAndTheCachedAnswerCompletesTheCall) {
  IoThread io;
  Link link(io.executor());
  // Like Tether firmware: runs the request once, caches the answer, answers a repeated id from the cache.
  std::atomic<int> executed{0};
  link.device->on_request([&](const DeviceRequest& request, FakeDevice& device) {
    if (request.repeat == 1) ++executed;
    const std::string answer = FakeDevice::response(request.opcode, "[0,42]", request.id);
    device.send(request.repeat == 1 ? FakeDevice::corrupt_crc(answer) : answer);
  });
  error_code error;
  const RomiResponse response = link.client->call("a", error);
  EXPECT_FALSE(error);
  EXPECT_EQ(response.values, json::parse("[0,42]"));
  EXPECT_EQ(response.attempts, 2);
  EXPECT_EQ(executed.load(), 1);
  const auto requests = link.device->requests();
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[1].frame, requests[0].frame);
  const LinkCounters counters = link.client->counters().link;
  EXPECT_EQ(counters.crc_errors, 1u);
  EXPECT_EQ(counters.retries, 1u);
  EXPECT_EQ(counters.frames_ok, 1u);
}

TEST(RomiClient, AnswerDamagedOnEverySendIsAnErrorCode) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::corrupt_crc(FakeDevice::response(request.opcode, "[0]", request.id)));
  });
  error_code error;
  const RomiResponse response = link.client->call("a", error);
  EXPECT_EQ(error, Error::crc_mismatch);
  EXPECT_EQ(response.code, -4);
  EXPECT_FALSE(response.answered);
  EXPECT_EQ(response.attempts, 3);
  EXPECT_EQ(link.client->counters().link.crc_errors, 3u);
}

// Log lines are no answers: a damaged one is no lost answer, nothing is sent again for it.
TEST(RomiClient, DamagedLogLineDoesNotFailTheCall) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send("#!half a log line:xxyy\r\n");  // bad dummy metadata (-7)
    device.send("#!damaged:yxxx\r\n");           // -2 in our decoder, but it began "#!"
    device.send("#!\r:xxxx\r\n");                 // -6: a CR right after "#!" (reference diagnostic line)
    device.send("#!#:xxxx\r\n");  // the reference's line for an offending '#': a resync, then an empty frame
    device.send(FakeDevice::response(request.opcode, "[0]", request.id));
  });
  const RomiResponse response = link.client->call("a");
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.attempts, 1);
  EXPECT_EQ(link.client->counters().link.retries, 0u);
  EXPECT_EQ(link.client->counters().link.framing_errors, 3u);
  EXPECT_EQ(link.client->counters().link.stale, 1u);  // the empty frame without id
}

// --- manual mode ------------------------------------------------------------------------------------------

TEST(RomiClient, ManualCallSendsXxxxAndMatchesTheAnswerByOpcode) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    if (!request.manual) {
      device.send(FakeDevice::response(request.opcode, "[0]", request.id));
      return;
    }
    device.send(FakeDevice::response('z', "[0,9]", 0));  // id 00 but another opcode: stale
    device.send("#a[0]:00e7\r\n");                         // the spec's vector for `#a:xxxx`
  });
  error_code error;
  const RomiResponse response = link.client->call_manual("a", error);
  EXPECT_FALSE(error);
  EXPECT_TRUE(response.ok());
  EXPECT_EQ(response.id, 0);
  EXPECT_EQ(link.device->received(), "#a:xxxx\r\n");
  EXPECT_EQ(link.client->counters().link.stale, 1u);
  // The next regular call skips id 0 (the reference firmware took the manual call's 00 as its last id).
  link.client->call("a");
  EXPECT_EQ(link.device->requests().back().frame, request_frame("a", 1));
}

TEST(RomiClient, ManualCallReceivesDeviceErrors) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request([](const DeviceRequest&, FakeDevice& device) { device.send("#a[-17]:00ac\r\n"); });
  const RomiResponse response = link.client->call_manual("a[1]");
  EXPECT_EQ(response.code, -17);
  EXPECT_EQ(link.device->received(), "#a[1]:xxxx\r\n");
}

TEST(RomiClient, ManualCallIsBoundedByTheEngine) {
  IoThread io;
  Link link(io.executor(), short_timing(100, 200));
  const Millis start = link.clock->now();
  auto outcome = start_call(*link.client, "a", /*manual=*/true);
  ASSERT_TRUE(link.device->wait_for_requests(1, kPrompt));
  Millis due = 0;
  ASSERT_TRUE(link.clock->advance_to_due(static_cast<Millis>(start + 100), due)) << "+" << due - start;
  ASSERT_EQ(outcome.wait_for(kPrompt), std::future_status::ready);
  EXPECT_EQ(outcome.get().error, Error::client_timeout);
}

// --- error category and counters --------------------------------------------------------------------------

TEST(RomiErrorCategory, ValuesAreRomiCodesAndMessagesTheTable) {
  const error_code error = make_error_code(Error::unknown_opcode);
  EXPECT_STREQ(error.category().name(), "tether.romi");
  EXPECT_EQ(error.value(), -16);
  EXPECT_EQ(error.message(), "unknown opcode");
  EXPECT_EQ(error, Error::unknown_opcode);
  EXPECT_EQ(make_romi_error_code(101).message(), "application error");
  EXPECT_FALSE(make_romi_error_code(0));
  EXPECT_EQ(make_error_code(Error::client_timeout), boost::system::errc::timed_out);
  EXPECT_NE(make_error_code(Error::crc_mismatch), boost::system::errc::timed_out);
}

TEST(RomiClient, CountersSeeFramesLogsAndStaleBetweenCalls) {
  IoThread io;
  Link link(io.executor());
  link.device->on_request(answer_with("[0]"));
  link.client->call("a");
  link.device->send(FakeDevice::response('a', "[0]", 200));  // nobody waits for it
  link.device->send("garbage#a[0]:00e8\r\n");                 // a resync, then a CRC mismatch
  ASSERT_TRUE(::tether::testing::eventually([&] { return link.client->counters().link.crc_errors == 1; }, kPrompt));
  const LinkCounters counters = link.client->counters().link;
  EXPECT_EQ(counters.frames_ok, 2u);
  EXPECT_EQ(counters.stale, 1u);
  EXPECT_EQ(counters.resyncs, 1u);
  EXPECT_EQ(counters.timeouts, 0u);
}

}  // namespace
}  // namespace tether::romi::testing
