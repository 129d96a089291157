// Host tests of the Romi device library (firmware/romi): the dispatcher's wire behaviour with in-memory
// streams and a fake clock. The same sources run on the AVR images; the interop tests drive those.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "RomiSerial.h"
#include "tether/core/crc.hpp"
#include "tether/romi/encoder.hpp"

namespace {

using namespace romiserial;

// --- test doubles ------------------------------------------------------------------------------------

class StringStreams final : public IInputStream, public IOutputStream {
 public:
  bool available() override { return !input.empty(); }
  bool read(char& c) override {
    if (input.empty()) return false;
    c = input.front();
    input.pop_front();
    return true;
  }
  bool write(char c) override {
    output.push_back(c);
    return true;
  }
  std::string take() {
    std::string out;
    out.swap(output);
    return out;
  }
  std::deque<char> input;
  std::string output;
};

uint32_t fake_now = 0;
uint32_t fake_clock() { return fake_now; }

// Handler side effects, reset by the fixture.
int runs = 0;
int16_t last_args[12];
std::string last_string;
RomiSerialBase* active = nullptr;  // the device the reentrant handler calls back

void ok(IRomiSerial* romi, int16_t* args, const char* text) {
  ++runs;
  for (int i = 0; i < 12; ++i) last_args[i] = args[i];
  last_string = text;
  romi->send_ok();
}
void silent(IRomiSerial*, int16_t*, const char*) { ++runs; }
void values(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send("[0,1,2]");
}
void fail(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_error(101, "I will try again tomorrow");
}
void twice(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_ok();
  romi->send_error(1, "second");
  romi->send("[0]");
}
void logs_then_ok(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->log("first");
  romi->log("multi\r\nline: yes");
  romi->send_ok();
}
void too_long(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send("[0,\"0123456789012345678901234567890123456789012345678901234567890123456789\"]");
}
void long_error(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_error(7, "0123456789012345678901234567890123456789012345678901234567890123456789012345");
}
void colon(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send("[0,\"a:b\"]");
}
void null_send(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send(nullptr);
}
void reentrant(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  active->handle_input();  // must not consume the bytes queued behind this request
  romi->send_ok();
}
void error_without_message(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_error(3, nullptr);
}
void slow(IRomiSerial* romi, int16_t*, const char*) {  // a handler that works for 500 ms, then answers
  ++runs;
  fake_now += 500;
  romi->send_ok();
}

const MessageHandler kHandlers[] = {
    {'a', 0, false, ok},         {'b', 0, false, silent},      {'c', 2, false, ok},
    {'d', 0, true, ok},          {'e', 0, false, values},      {'f', 0, false, fail},
    {'m', 12, false, ok},        {'2', 0, false, twice},       {'g', 0, false, logs_then_ok},
    {'L', 0, false, too_long},   {'E', 0, false, long_error},  {'k', 0, false, colon},
    {'n', 0, false, null_send},  {'r', 0, false, reentrant},   {'x', 0, false, error_without_message},
    {'w', 0, false, slow},
};
constexpr uint8_t kHandlerCount = sizeof(kHandlers) / sizeof(kHandlers[0]);

std::string response(char opcode, const std::string& body, uint8_t id) {
  uint8_t buffer[256];
  const auto frame = tether::romi::encode_response(
      opcode, tether::ByteView::from_chars(body.data(), body.size()), id, tether::MutableByteView(buffer));
  EXPECT_TRUE(frame.ok());
  return std::string(reinterpret_cast<const char*>(buffer), frame.value());
}

std::string request(const std::string& payload, uint8_t id) {
  uint8_t buffer[256];
  const auto frame = tether::romi::encode_request(tether::ByteView::from_chars(payload.data(), payload.size()), id,
                                                  tether::MutableByteView(buffer));
  EXPECT_TRUE(frame.ok());
  return std::string(reinterpret_cast<const char*>(buffer), frame.value());
}

class RomiSerialTest : public ::testing::Test {
 protected:
  RomiSerialTest() : device(streams, streams, kHandlers, kHandlerCount, fake_clock) {
    fake_now = 0;
    runs = 0;
    last_string.clear();
    active = &device;
  }
  // Feeds `bytes` and returns everything the device wrote.
  std::string exchange(const std::string& bytes) {
    streams.input.insert(streams.input.end(), bytes.begin(), bytes.end());
    device.handle_input();
    return streams.take();
  }

  StringStreams streams;
  RomiSerial device;
};

// --- the spec's vectors --------------------------------------------------------------------------------

TEST_F(RomiSerialTest, SpecVectors) {
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(exchange("#a[1]:xxxx\r\n"), "#a[-17]:00ac\r\n");
  EXPECT_EQ(exchange("#z:xxxx\r\n"), "#z[-16]:0001\r\n");
  EXPECT_EQ(exchange("#e:xxxx\r\n"), "#e[0,1,2]:00dc\r\n");
  EXPECT_EQ(exchange("#f:32dd\r\n"), "#f[101,\"I will try again tomorrow\"]:32c3\r\n");
}

TEST_F(RomiSerialTest, SpecEnvelopeErrorVectors) {
  EXPECT_EQ(exchange("#e:7b00\r\n"), response('e', "[-4]", 0x7b));
  EXPECT_EQ(exchange("#e:\r\n"), response('e', "[-2]", 0));
  EXPECT_EQ(exchange("#e\r\n"), response('e', "[-6]", 0));
  EXPECT_EQ(runs, 0);
  EXPECT_EQ(device.counters().link.crc_errors, 1u);
  EXPECT_EQ(device.counters().link.framing_errors, 2u);
}

TEST_F(RomiSerialTest, EveryEnvelopeErrorIsAnsweredWithItsCode) {
  EXPECT_EQ(exchange("#a:0g00\r\n"), response('a', "[-2]", 0));       // id not lowercase hex
  EXPECT_EQ(exchange("#a:0A00\r\n"), response('a', "[-2]", 0));       // uppercase rejected
  EXPECT_EQ(exchange("#a:05zz\r\n"), response('a', "[-3]", 5));       // CRC digits
  EXPECT_EQ(exchange("#a:xxxx\rX"), response('a', "[-5]", 0));        // no LF after CR
  EXPECT_EQ(exchange("#a:xxyy\r\n"), response('a', "[-7]", 0));       // bad dummy metadata
  EXPECT_EQ(runs, 0);
}

TEST(DeviceLinkCounters, ConvertToLinkCountersFieldByField) {
  tether::romi::device::DeviceLinkCounters device;
  device.frames_ok = 1;
  device.crc_errors = 2;
  device.framing_errors = 3;
  device.oversize_frames = 4;
  device.resyncs = 5;
  device.partial_timeouts = 6;
  device.duplicates = 7;
  const tether::LinkCounters link = device;
  EXPECT_EQ(link.frames_ok, 1u);
  EXPECT_EQ(link.crc_errors, 2u);
  EXPECT_EQ(link.framing_errors, 3u);
  EXPECT_EQ(link.oversize_frames, 4u);
  EXPECT_EQ(link.resyncs, 5u);
  EXPECT_EQ(link.partial_timeouts, 6u);
  EXPECT_EQ(link.duplicates, 7u);
  // What a device never counts stays 0.
  EXPECT_EQ(link.stale + link.retries + link.timeouts + link.resets + link.failsafes, 0u);
}

TEST_F(RomiSerialTest, GarbageBeforeTheFrameIsIgnored) {
  EXPECT_EQ(exchange("noise\r\n!!#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_GE(device.counters().link.resyncs, 1u);
}

TEST_F(RomiSerialTest, HashRestartsTheFrame) {
  EXPECT_EQ(exchange("#c[1,#a:xxxx\r\n"), "#a[0]:00e7\r\n");
}

TEST_F(RomiSerialTest, RequestWithIdGetsItsIdBack) {
  EXPECT_EQ(exchange(request("a", 0x7b)), response('a', "[0]", 0x7b));
  EXPECT_EQ(exchange("#e:7b04\r\n"), "#e[0,1,2]:7b" + response('e', "[0,1,2]", 0x7b).substr(12));
}

// --- dispatch ------------------------------------------------------------------------------------------

TEST_F(RomiSerialTest, DispatchOrderAndCodes) {
  EXPECT_EQ(exchange(request("z", 1)), response('z', "[-16]", 1));
  EXPECT_EQ(exchange(request("c[1]", 2)), response('c', "[-17]", 2));
  EXPECT_EQ(exchange(request("d", 3)), response('d', "[-18]", 3));
  EXPECT_EQ(exchange(request("a[\"x\"]", 4)), response('a', "[-19]", 4));
  // Argument count is checked before the string: "d[1]" lacks the string AND has a stray integer.
  EXPECT_EQ(exchange(request("d[1]", 5)), response('d', "[-17]", 5));
  EXPECT_EQ(runs, 0);
  EXPECT_EQ(exchange(request("b", 6)), response('b', "[-20]", 6));
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(device.counters().silent_handlers, 1u);
  EXPECT_EQ(device.counters().rejected, 5u);
}

TEST_F(RomiSerialTest, ParserErrorsUseTheFramesOpcodeAndId) {
  EXPECT_EQ(exchange(request("a", 9)), response('a', "[0]", 9));
  EXPECT_EQ(exchange(request("c[x]", 10)), response('c', "[-8]", 10));
  EXPECT_EQ(exchange(request("c[1,2,3,4,5,6,7,8,9,10,11,12,13]", 11)), response('c', "[-9]", 11));
  EXPECT_EQ(exchange(request("c[1,40000]", 12)), response('c', "[-10]", 12));
  EXPECT_EQ(exchange(request("d[\"012345678901234567890123456789012\"]", 13)), response('d', "[-11]", 13));
  EXPECT_EQ(exchange(request("d[\"a<b\"]", 14)), response('d', "[-12]", 14));
  EXPECT_EQ(exchange(request("d[\"a\",\"b\"]", 15)), response('d', "[-13]", 15));
  EXPECT_EQ(exchange(request("#", 16)).substr(0, 2), "#_");  // '#' restarts: becomes an empty frame
  EXPECT_EQ(exchange(request("%", 17)), response('_', "[-14]", 17));
}

TEST_F(RomiSerialTest, ErrorAfterAGoodFrameDoesNotBorrowItsId) {
  EXPECT_EQ(exchange(request("a", 0x42)), response('a', "[0]", 0x42));
  // A frame with no metadata: the id read so far is none, so 00 (not the previous frame's 42).
  EXPECT_EQ(exchange("#c\r\n"), response('c', "[-6]", 0));
  EXPECT_EQ(exchange("#c:\r\n"), response('c', "[-2]", 0));
}

TEST_F(RomiSerialTest, ArgumentsAndStringReachTheHandler) {
  EXPECT_EQ(exchange(request("m[1,-2,3,-4,5,-6,7,-8,9,-10,32767,-32768]", 1)), response('m', "[0]", 1));
  const int16_t expected[12] = {1, -2, 3, -4, 5, -6, 7, -8, 9, -10, 32767, -32768};
  for (int i = 0; i < 12; ++i) EXPECT_EQ(last_args[i], expected[i]) << i;
  EXPECT_EQ(last_string, "");
  EXPECT_EQ(exchange(request("d[\"Hello world!\"]", 2)), response('d', "[0]", 2));
  EXPECT_EQ(last_string, "Hello world!");
}

TEST_F(RomiSerialTest, LogLinesGoOutBeforeTheResponse) {
  EXPECT_EQ(exchange("#g:xxxx\r\n"), "#!first:xxxx\r\n#!multi  line: yes:xxxx\r\n" + response('g', "[0]", 0));
}

TEST_F(RomiSerialTest, ColonInTheBodyIsSentAsDash) {
  EXPECT_EQ(exchange("#k:xxxx\r\n"), response('k', "[0,\"a-b\"]", 0));
}

TEST_F(RomiSerialTest, ErrorWithoutMessage) { EXPECT_EQ(exchange("#x:xxxx\r\n"), response('x', "[3]", 0)); }

TEST_F(RomiSerialTest, OnlyTheFirstReplyOfAHandlerIsSent) {
  EXPECT_EQ(exchange("#2:xxxx\r\n"), response('2', "[0]", 0));
  EXPECT_EQ(device.counters().extra_replies, 2u);
}

TEST_F(RomiSerialTest, RepliesOutsideAHandlerAreIgnoredButLogsAreSent) {
  device.send_ok();
  device.send_error(1, "x");
  device.send("[0]");
  EXPECT_EQ(streams.take(), "");
  EXPECT_EQ(device.counters().extra_replies, 3u);
  device.log("hello");
  EXPECT_EQ(streams.take(), "#!hello:xxxx\r\n");
}

TEST_F(RomiSerialTest, NullSendCountsAsNoReply) {
  EXPECT_EQ(exchange("#n:xxxx\r\n"), response('n', "[-20]", 0));
}

TEST_F(RomiSerialTest, ReplyTooLongIsAnsweredWithMinus31) {
  EXPECT_EQ(exchange(request("L", 3)), response('L', "[-31]", 3));
  EXPECT_EQ(exchange(request("E", 4)), response('E', "[-31]", 4));
  EXPECT_EQ(device.counters().replies_too_long, 2u);
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, LargestReplyThatFits) {
  // 72 bytes: '#', opcode, 63-character body, ':', id, CRC, CRLF.
  static std::string body;
  body = "[0,\"" + std::string(57, 'a') + "\"]";
  ASSERT_EQ(body.size(), 63u);
  const MessageHandler handlers[] = {{'q', 0, false, [](IRomiSerial* romi, int16_t*, const char*) {
                                        romi->send(body.c_str());
                                      }}};
  device.set_handlers(handlers, 1);
  EXPECT_EQ(exchange("#q:xxxx\r\n"), response('q', body, 0));
  body += " ";  // one byte more: -31
  EXPECT_EQ(exchange(request("q", 1)), response('q', "[-31]", 1));
}

TEST_F(RomiSerialTest, ARepeatGetsTheWholeCachedReplyWhateverItsBody) {
  // The device keeps no size for the cached reply: it finds the frame's end after its ':' (the first
  // after the opcode: a body's ':' is sent as '-'). Bodies with ':', CR and LF, the shortest and the
  // longest reply.
  static std::string body;
  const MessageHandler handlers[] = {{'q', 0, false, [](IRomiSerial* romi, int16_t*, const char*) {
                                        ++runs;
                                        romi->send(body.c_str());
                                      }}};
  device.set_handlers(handlers, 1);
  const std::string bodies[] = {"[0,\"a:b\"]", "[0,\"\r\n:\r\n\"]", "[]", "[0,\"" + std::string(57, ':') + "\"]"};
  uint8_t id = 1;
  for (const std::string& text : bodies) {
    body = text;
    const std::string reply = response('q', text, id);
    EXPECT_EQ(exchange(request("q", id)), reply) << text;
    EXPECT_EQ(exchange(request("q", id)), reply) << text;  // the cached copy, byte for byte
    ++id;
  }
  EXPECT_EQ(response('q', bodies[3], 4).size(), 72u);
  EXPECT_EQ(runs, 4);
  EXPECT_EQ(device.counters().link.duplicates, 4u);
}

TEST_F(RomiSerialTest, HandleInputInsideAHandlerDoesNothing) {
  EXPECT_EQ(exchange("#r:xxxx\r\n#a:xxxx\r\n"), "#r[0]:00" + response('r', "[0]", 0).substr(8) + "#a[0]:00e7\r\n");
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, ReceivedLogFrameIsAnInvalidOpcode) {
  EXPECT_EQ(exchange("#!hello:xxxx\r\n"), response('_', "[-14]", 0));
}

// --- exactly-once (B3) and ids (B6) ----------------------------------------------------------------------

TEST_F(RomiSerialTest, RepeatedRequestGetsTheCachedResponseWithoutRunningTheHandler) {
  const std::string first = exchange(request("c[1,2]", 7));
  EXPECT_EQ(first, response('c', "[0]", 7));
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(exchange(request("c[1,2]", 7)), first);
  EXPECT_EQ(exchange(request("c[1,2]", 7)), first);
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(device.counters().link.duplicates, 2u);
  EXPECT_EQ(device.counters().executed, 1u);
}

// The handler's string is terminated in place in the frame (its closing quote is the NUL); the quote
// must be back before the frame's bytes become the cache's key, or a re-sent copy would run again.
TEST_F(RomiSerialTest, ARepeatedStringRequestIsAnsweredFromTheCache) {
  for (const std::string payload : {"d[\"Hello world!\"]", "d[\"\"]"}) {
    runs = 0;
    const std::string first = exchange(request(payload, 4));
    EXPECT_EQ(first, response('d', "[0]", 4)) << payload;
    EXPECT_EQ(last_string, payload.substr(3, payload.size() - 5)) << payload;
    EXPECT_EQ(exchange(request(payload, 4)), first) << payload;
    EXPECT_EQ(runs, 1) << payload;
  }
  EXPECT_EQ(device.counters().link.duplicates, 2u);
}

TEST_F(RomiSerialTest, NeverAnswersDuplicate) {
  for (int i = 0; i < 3; ++i) {
    for (const char* payload : {"a", "e", "f", "b", "c[1,2]"}) {
      EXPECT_EQ(exchange(request(payload, 1)).find("[-15]"), std::string::npos) << payload;
    }
  }
}

TEST_F(RomiSerialTest, CachedResponseSurvivesErrorsInBetween) {
  const std::string first = exchange(request("e", 0x20));
  EXPECT_EQ(exchange("#e:2000\r\n"), response('e', "[-4]", 0x20));  // a damaged copy of the retry
  EXPECT_EQ(exchange(request("z", 0x21)), response('z', "[-16]", 0x21));
  EXPECT_EQ(exchange(request("e", 0x20)), first);
  EXPECT_EQ(runs, 1);
}

TEST_F(RomiSerialTest, ApplicationErrorsAndMissingRepliesAreCachedToo) {
  const std::string failed = exchange(request("f", 1));
  EXPECT_EQ(exchange(request("f", 1)), failed);
  const std::string silent_reply = exchange(request("b", 2));
  EXPECT_EQ(silent_reply, response('b', "[-20]", 2));
  EXPECT_EQ(exchange(request("b", 2)), silent_reply);
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, SameIdDifferentRequestRuns) {
  EXPECT_EQ(exchange(request("c[1,2]", 5)), response('c', "[0]", 5));
  EXPECT_EQ(exchange(request("c[1,3]", 5)), response('c', "[0]", 5));
  EXPECT_EQ(last_args[1], 3);
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, SameIdAndSameFingerprintButOtherBytesRuns) {
  // The two payloads have the same length and the same CRC-16/MCRF4XX (0x9754, checked below): the
  // cache used to key on (id, that CRC) and answered the second with the first's reply, unexecuted.
  const tether::ByteView first = tether::ByteView::from_literal("c[1888,1005]");
  const tether::ByteView second = tether::ByteView::from_literal("c[2260,1000]");
  ASSERT_EQ(tether::Crc16Mcrf4xx::compute(first), tether::Crc16Mcrf4xx::compute(second));
  EXPECT_EQ(exchange(request("c[1888,1005]", 9)), response('c', "[0]", 9));
  EXPECT_EQ(exchange(request("c[2260,1000]", 9)), response('c', "[0]", 9));
  EXPECT_EQ(last_args[0], 2260);
  EXPECT_EQ(last_args[1], 1000);
  EXPECT_EQ(runs, 2);
  EXPECT_EQ(device.counters().link.duplicates, 0u);
}

TEST_F(RomiSerialTest, OnlyTheLastRequestIsRemembered) {
  exchange(request("a", 1));
  exchange(request("e", 2));
  EXPECT_EQ(exchange(request("a", 1)), response('a', "[0]", 1));
  EXPECT_EQ(runs, 3);
}

TEST_F(RomiSerialTest, FreshDeviceAcceptsId255) {
  EXPECT_EQ(exchange(request("a", 255)), response('a', "[0]", 255));
  EXPECT_EQ(runs, 1);
}

TEST_F(RomiSerialTest, ManualRequestsBypassTheCacheAndDoNotPoisonIdZero) {
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(runs, 2);
  EXPECT_EQ(exchange(request("a", 0)), "#a[0]:00e7\r\n");  // id 0 after manual ones: runs
  EXPECT_EQ(runs, 3);
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");  // manual after id 0: runs, cache kept
  EXPECT_EQ(runs, 4);
  EXPECT_EQ(exchange(request("a", 0)), "#a[0]:00e7\r\n");  // the id-0 request is still a repeat
  EXPECT_EQ(runs, 4);
}

// The cache keeps the reply it answers repeats with in the device's one reply buffer: a manual
// request's reply (different opcode, different body) must not replace it.
TEST_F(RomiSerialTest, ManualRequestInBetweenDoesNotChangeTheCachedReply) {
  const std::string cached = exchange(request("e", 9));
  EXPECT_EQ(cached, response('e', "[0,1,2]", 9));
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(exchange(request("e", 9)), cached);
  EXPECT_EQ(runs, 2);
}

// A new host session that starts with the previous one's last id and command (1 in 256 with random
// first ids) must get its command executed, while every re-send of a call (all within the host's 2 s
// budget) is still answered from the cache: the cached reply lives exactly 2 s after it was sent.
TEST_F(RomiSerialTest, CachedReplyAnswersRepeatsUpToTheCallBudgetAfterItWasSent) {
  fake_now = 1000;
  const std::string first = exchange(request("c[1,2]", 5));
  EXPECT_EQ(runs, 1);
  fake_now = 1000 + 2000;  // the latest a re-send of the same call can come
  EXPECT_EQ(exchange(request("c[1,2]", 5)), first);
  EXPECT_EQ(runs, 1);
  fake_now = 1000 + 2001;  // a new session's identical command
  EXPECT_EQ(exchange(request("c[1,2]", 5)), first);
  EXPECT_EQ(runs, 2);
  EXPECT_EQ(device.counters().executed, 2u);
  EXPECT_EQ(device.counters().link.duplicates, 1u);
  // The run at 3001 is cached in turn, for 2 s from then.
  fake_now = 3001 + 2000;
  exchange(request("c[1,2]", 5));
  EXPECT_EQ(runs, 2);
  fake_now = 3001 + 2001;
  exchange(request("c[1,2]", 5));
  EXPECT_EQ(runs, 3);
}

TEST_F(RomiSerialTest, CachedReplyExpiresWhileTheDeviceIsIdle) {
  exchange(request("a", 9));
  fake_now = 2000;
  EXPECT_EQ(exchange(""), "");
  fake_now = 2001;
  EXPECT_EQ(exchange(""), "");  // nothing to say, but the cache is gone
  fake_now = 0x90000000u;       // far later (past half the clock's range): still gone, not wrapped back
  EXPECT_EQ(exchange(request("a", 9)), response('a', "[0]", 9));
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, CacheLifetimeStartsWhenTheReplyIsSentNotWhenTheRequestArrived) {
  fake_now = 0;
  const std::string first = exchange(request("w", 3));  // the handler answers at 500
  EXPECT_EQ(fake_now, 500u);
  fake_now = 500 + 2000;
  EXPECT_EQ(exchange(request("w", 3)), first);
  EXPECT_EQ(runs, 1);
  fake_now = 500 + 2001;
  exchange(request("w", 3));
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, CacheLifetimeWorksAcrossTheClockWrap) {
  fake_now = 0xFFFFF000u;
  const std::string first = exchange(request("a", 7));
  fake_now = 0xFFFFF000u + 2000u;  // wrapped
  EXPECT_EQ(exchange(request("a", 7)), first);
  EXPECT_EQ(runs, 1);
  fake_now = 0xFFFFF000u + 2001u;
  exchange(request("a", 7));
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, BytesAfterASlowHandlerAreTimedFromItsReply) {
  // The clock is read once per handle_input and once after each handler, never per byte: a request
  // queued behind a 500 ms handler starts its 1 s deadline after the handler, not before it.
  fake_now = 0;
  const std::string out = exchange(request("w", 1) + "#a[");
  EXPECT_EQ(out, response('w', "[0]", 1));
  fake_now = 1499;  // 999 ms after the slow reply: the partial request is still in time
  EXPECT_EQ(exchange(""), "");
  fake_now = 1500;
  EXPECT_EQ(exchange(""), response('a', "[-30]", 0));
}

// --- overlong frames (B1) ------------------------------------------------------------------------------

TEST_F(RomiSerialTest, PayloadOf58CharactersIsAccepted) {
  const std::string payload = "m[-1234,-1234,-1234,-1234,-1234,-1234,-1234,-1234,1,1,1,1]";
  ASSERT_EQ(payload.size(), 58u);
  EXPECT_EQ(exchange(request(payload, 3)), response('m', "[0]", 3));
  EXPECT_EQ(exchange("#" + payload + ":xxxx\r\n"), response('m', "[0]", 0));
  EXPECT_EQ(runs, 2);
}

TEST_F(RomiSerialTest, OverlongFrameGetsExactlyOneMinus1) {
  const std::string payload = "m[-1234,-1234,-1234,-1234,-1234,-1234,-1234,-1234,10,1,1,1]";
  ASSERT_EQ(payload.size(), 59u);
  EXPECT_EQ(exchange(request(payload, 3)), response('m', "[-1]", 0));
  EXPECT_EQ(exchange("#" + payload + ":xxxx\r\n"), response('m', "[-1]", 0));
  EXPECT_EQ(exchange("#" + std::string(200, '-') + ":xxxx\r\n"), response('_', "[-1]", 0));
  EXPECT_EQ(runs, 0);
  EXPECT_EQ(device.counters().link.oversize_frames, 3u);
  // And the device is in step afterwards.
  EXPECT_EQ(exchange(request("a", 4)), response('a', "[0]", 4));
}

// --- controller timeout (B7) ---------------------------------------------------------------------------

TEST_F(RomiSerialTest, IncompleteRequestIsDroppedAfterOneSecond) {
  fake_now = 100;
  EXPECT_EQ(exchange("#a[1"), "");
  fake_now = 1099;
  EXPECT_EQ(exchange(""), "");
  fake_now = 1100;
  EXPECT_EQ(exchange(""), response('a', "[-30]", 0));
  EXPECT_EQ(exchange(""), "");  // once
  EXPECT_EQ(exchange("]:xxxx\r\n"), "");  // the rest of the late frame is skipped
  EXPECT_EQ(exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(device.counters().link.partial_timeouts, 1u);
  EXPECT_EQ(runs, 1);
}

TEST_F(RomiSerialTest, LateByteDoesNotCompleteAnExpiredRequest) {
  fake_now = 0;
  exchange("#a:xxxx\r");
  fake_now = 1500;  // the LF arrives after the deadline: -30, not [0]
  EXPECT_EQ(exchange("\n"), response('a', "[-30]", 0));
  EXPECT_EQ(runs, 0);
}

TEST_F(RomiSerialTest, NewHashRestartsTheDeadline) {
  fake_now = 0;
  exchange("#a[");
  fake_now = 900;
  exchange("#a");
  fake_now = 1800;
  EXPECT_EQ(exchange(":xxxx\r\n"), "#a[0]:00e7\r\n");
}

TEST_F(RomiSerialTest, TimeoutWithoutOpcodeUsesUnderscore) {
  fake_now = 0;
  exchange("#");
  fake_now = 1000;
  EXPECT_EQ(exchange(""), response('_', "[-30]", 0));
}

TEST_F(RomiSerialTest, CompletedAndRejectedFramesHaveNoDeadline) {
  exchange("#a:xxxx\r\n");
  exchange("#a:zz\r\n");  // -2, then skipping until '#'
  fake_now = 5000;
  EXPECT_EQ(exchange(""), "");
}

TEST_F(RomiSerialTest, DeadlineWorksAcrossTheClockWrap) {
  fake_now = 0xFFFFFF00u;
  exchange("#a[");
  fake_now = 0xFFFFFF00u + 999u;
  EXPECT_EQ(exchange(""), "");
  fake_now = 0xFFFFFF00u + 1000u;
  EXPECT_EQ(exchange(""), response('a', "[-30]", 0));
}

// The device parses a frame and looks its handler up at the frame's '\r'; a table replaced before the
// '\n' arrives is the one that answers.
TEST_F(RomiSerialTest, HandlersReplacedBetweenTheFramesCrAndLfAreTheOnesUsed) {
  const std::string frame = request("e", 3);
  EXPECT_EQ(exchange(frame.substr(0, frame.size() - 1)), "");  // up to the '\r'
  static const MessageHandler kOnlyA[] = {{'a', 0, false, ok}};
  device.set_handlers(kOnlyA, 1);
  EXPECT_EQ(exchange("\n"), response('e', "[-16]", 3));
  EXPECT_EQ(runs, 0);
}

TEST(RomiSerialNoClock, WithoutAClockThereIsNoDeadline) {
  StringStreams streams;
  RomiSerial device(streams, streams, kHandlers, kHandlerCount, nullptr);
  streams.input.assign({'#', 'a'});
  device.handle_input();
  device.handle_timeouts(1000000);  // sans-I/O use can still pass its own time
  EXPECT_EQ(streams.take(), response('a', "[-30]", 0));
}

TEST(RomiSerialFreshState, ADeviceBuiltOverUsedMemoryStartsFresh) {
  // The device's zero state is its own doing (a value-initialized base), not static storage's zeros: a
  // device on the stack or in reused memory starts as fresh as a static one.
  alignas(RomiSerial) unsigned char storage[sizeof(RomiSerial)];
  std::memset(storage, 0xa5, sizeof storage);
  StringStreams streams;
  fake_now = 0;
  runs = 0;
  RomiSerial* device = new (storage) RomiSerial(streams, streams, kHandlers, kHandlerCount, fake_clock);
  EXPECT_FALSE(device->in_handler());
  EXPECT_EQ(device->counters().executed + device->counters().link.duplicates, 0u);
  // Not a repeat of anything, not refused as a call from inside a handler: it runs.
  const std::string first = request("a", 0xa5);
  streams.input.assign(first.begin(), first.end());
  device->handle_input();
  EXPECT_EQ(streams.take(), response('a', "[0]", 0xa5));
  EXPECT_EQ(runs, 1);
  device->~RomiSerial();
}

TEST(RomiSerialNoHandlers, EverythingIsUnknown) {
  StringStreams streams;
  RomiSerial device(streams, streams, nullptr, 0, fake_clock);
  const std::string frame = "#a:xxxx\r\n";
  streams.input.assign(frame.begin(), frame.end());
  device.handle_input();
  EXPECT_EQ(streams.take(), response('a', "[-16]", 0));
}

// --- sized devices (BasicRomiSerial) --------------------------------------------------------------------

// The device of the romi-bench image: requests of romi-bench's handlers (a string of up to 32 characters:
// d["..."] is 37), replies up to `#e[0,1,2]:iicc\r\n` (16 bytes).
using BenchDevice = BasicRomiSerial<37, 16>;
// The smallest: requests that are an opcode alone, replies `[0]` and the protocol's `[-NN]`.
using SmallestDevice = BasicRomiSerial<RomiSerialBase::kMinPayloadCapacity, RomiSerialBase::kMinReplyCapacity>;

static_assert(RomiSerial::kPayloadCapacity == 58 && RomiSerial::kReplyCapacity == 72, "the spec's maxima");
static_assert(BenchDevice::kBufferSize == 42 + 16 + 37, "frame (payload and metadata), reply, key");
static_assert(SmallestDevice::kPayloadCapacity == 1 && SmallestDevice::kReplyCapacity == 14, "");
static_assert(sizeof(SmallestDevice) < sizeof(BenchDevice) && sizeof(BenchDevice) < sizeof(RomiSerial),
              "a device pays only for its buffers");

// A device of type `Device` with the fixture's handlers, fed through its streams.
template <typename Device>
struct Bench {
  Bench() : device(streams, streams, kHandlers, kHandlerCount, fake_clock) {}
  std::string exchange(const std::string& bytes) {
    streams.input.insert(streams.input.end(), bytes.begin(), bytes.end());
    device.handle_input();
    return streams.take();
  }
  StringStreams streams;
  Device device;
};

void expect_same_counters(const DeviceCounters& a, const DeviceCounters& b, const std::string& what) {
  EXPECT_EQ(a.link.frames_ok, b.link.frames_ok) << what;
  EXPECT_EQ(a.link.crc_errors, b.link.crc_errors) << what;
  EXPECT_EQ(a.link.framing_errors, b.link.framing_errors) << what;
  EXPECT_EQ(a.link.oversize_frames, b.link.oversize_frames) << what;
  EXPECT_EQ(a.link.resyncs, b.link.resyncs) << what;
  EXPECT_EQ(a.link.partial_timeouts, b.link.partial_timeouts) << what;
  EXPECT_EQ(a.link.duplicates, b.link.duplicates) << what;
  EXPECT_EQ(a.executed, b.executed) << what;
  EXPECT_EQ(a.rejected, b.rejected) << what;
  EXPECT_EQ(a.silent_handlers, b.silent_handlers) << what;
  EXPECT_EQ(a.extra_replies, b.extra_replies) << what;
  EXPECT_EQ(a.replies_too_long, b.replies_too_long) << what;
}

// One step of a script: the clock moves by `advance_ms`, then `bytes` arrive and handle_input runs.
struct Step {
  uint32_t advance_ms;
  std::string bytes;
};

// Runs `script` through a fresh `Device` from time 0; returns everything it wrote.
template <typename Device>
std::string run_script(const std::vector<Step>& script, DeviceCounters& counters) {
  fake_now = 0;
  const auto bench = std::make_unique<Bench<Device>>();
  active = &bench->device;
  std::string out;
  for (const Step& step : script) {
    fake_now += step.advance_ms;
    out += bench->exchange(step.bytes);
  }
  counters = bench->device.counters();
  active = nullptr;
  return out;
}

// A script of requests that all fit BenchDevice (payloads up to 37 characters, replies up to 16 bytes),
// drawn from `seed` (fixed: the scripts are the same on every run): good requests with a few ids (so
// re-sends hit the cache, and later the same id and bytes run again), manual ones, damaged copies (a
// byte replaced: CRC, id, syntax errors), frames cut short (answered -30 a second later), garbage
// between frames, and clock steps around the deadline and the cache's lifetime.
std::vector<Step> sized_script(uint32_t seed) {
  static const char* const kPayloads[] = {
      "a", "b", "c[1,2]", "c[-32768,32767]", "c[1]", "d[\"Hello there\"]",
      "d[\"0123456789abcdefghijklmnopqrstuv\"]",  // 37 characters: the largest BenchDevice takes
      "d", "a[\"x\"]", "e", "x", "w", "n", "2", "g", "z", "c[x]", "%", "m[1,2,3,4,5,6,7,8,9,10,11,12]",
      "r", "c[1,40000]", "d[\"a<b\"]", "d[\"a\",\"b\"]"};
  static const uint8_t kIds[] = {0, 1, 2, 7, 255};
  static const uint32_t kSteps[] = {0, 0, 0, 1, 10, 500, 999, 1000, 1999, 2000, 2001};
  std::mt19937 random(seed);
  const auto pick = [&](size_t n) { return static_cast<size_t>(random() % n); };
  std::vector<Step> script;
  std::string last;
  for (int i = 0; i < 200; ++i) {
    const std::string payload = kPayloads[pick(sizeof kPayloads / sizeof kPayloads[0])];
    std::string bytes;
    switch (pick(8)) {
      case 0:
        bytes = "#" + payload + ":xxxx\r\n";
        break;
      case 1: {  // a damaged copy: one byte before its "\r\n" replaced (the frame no longer than before)
        bytes = request(payload, kIds[pick(sizeof kIds)]);
        const size_t at = 1 + pick(bytes.size() - 3);
        bytes[at] = "0a:g[\"#\r\n"[pick(9)];
        break;
      }
      case 2:  // the same bytes again (a re-send)
        bytes = last.empty() ? request(payload, 1) : last;
        break;
      case 3:  // a frame cut short, then garbage (at most 20 + 8 bytes: within both buffers)
        bytes = request(payload, kIds[pick(sizeof kIds)]).substr(0, 1 + pick(20));
        bytes += std::string(pick(8), "x]1,\"!"[pick(6)]);
        break;
      default:
        bytes = request(payload, kIds[pick(sizeof kIds)]);
        break;
    }
    last = bytes;
    script.push_back(Step{kSteps[pick(sizeof kSteps / sizeof kSteps[0])], bytes});
  }
  return script;
}

TEST(BasicRomiSerial, ASizedDeviceAnswersEveryRequestThatFitsItExactlyAsRomiSerialDoes) {
  DeviceCounters total;
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    const std::vector<Step> script = sized_script(seed);
    DeviceCounters full_counters;
    DeviceCounters sized_counters;
    DeviceCounters exact_counters;
    const std::string full = run_script<RomiSerial>(script, full_counters);
    const std::string sized = run_script<BenchDevice>(script, sized_counters);
    const std::string exact = run_script<BasicRomiSerial<58, 72>>(script, exact_counters);
    const std::string what = "seed " + std::to_string(seed);
    EXPECT_EQ(sized, full) << what;
    EXPECT_EQ(exact, full) << what;
    expect_same_counters(sized_counters, full_counters, what);
    expect_same_counters(exact_counters, full_counters, what);
    total.link.duplicates += full_counters.link.duplicates;
    total.link.partial_timeouts += full_counters.link.partial_timeouts;
    total.link.crc_errors += full_counters.link.crc_errors;
    total.link.framing_errors += full_counters.link.framing_errors;
    total.executed += full_counters.executed;
    total.silent_handlers += full_counters.silent_handlers;
  }
  // The scripts reach what they are for: the cache, the deadline, damaged frames, every handler path.
  EXPECT_GT(total.link.duplicates, 100u);
  EXPECT_GT(total.link.partial_timeouts, 100u);
  EXPECT_GT(total.link.crc_errors, 100u);
  EXPECT_GT(total.link.framing_errors, 100u);
  EXPECT_GT(total.executed, 1000u);
  EXPECT_GT(total.silent_handlers, 10u);
}

TEST(BasicRomiSerial, TheSpecVectorsOnASizedDevice) {
  fake_now = 0;
  Bench<BenchDevice> bench;
  EXPECT_EQ(bench.exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(bench.exchange("#a[1]:xxxx\r\n"), "#a[-17]:00ac\r\n");
  EXPECT_EQ(bench.exchange("#z:xxxx\r\n"), "#z[-16]:0001\r\n");
  EXPECT_EQ(bench.exchange("#e:xxxx\r\n"), "#e[0,1,2]:00dc\r\n");  // 16 bytes: the whole reply buffer
  EXPECT_EQ(bench.exchange("#e:7b00\r\n"), response('e', "[-4]", 0x7b));
  EXPECT_EQ(bench.exchange("#e:\r\n"), response('e', "[-2]", 0));
  EXPECT_EQ(bench.exchange("#e\r\n"), response('e', "[-6]", 0));
  EXPECT_EQ(bench.device.payload_capacity(), 37);
  EXPECT_EQ(bench.device.reply_capacity(), 16);
}

TEST(BasicRomiSerial, ARequestLongerThanItsPayloadCapacityIsAnsweredTooLongOnce) {
  fake_now = 0;
  runs = 0;
  Bench<BasicRomiSerial<8, 16>> bench;
  EXPECT_EQ(bench.exchange(request("c[10,20]", 1)), response('c', "[0]", 1));  // 8 characters: fits
  EXPECT_EQ(last_args[0], 10);
  // 9 characters: one -1 (too long), with the frame's opcode and no id (the metadata was never read),
  // whether the request has an id or is typed by hand; the handler does not run.
  EXPECT_EQ(bench.exchange(request("c[100,20]", 2)), response('c', "[-1]", 0));
  EXPECT_EQ(bench.exchange("#c[100,20]:xxxx\r\n"), response('c', "[-1]", 0));
  EXPECT_EQ(bench.exchange("#" + std::string(100, 'd') + ":xxxx\r\n"), response('d', "[-1]", 0));
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(bench.device.counters().link.oversize_frames, 3u);
  EXPECT_EQ(bench.device.counters().rejected, 3u);
  // A host re-sends the same bytes on an envelope error: the same answer again, nothing cached.
  EXPECT_EQ(bench.exchange(request("c[100,20]", 2)), response('c', "[-1]", 0));
  EXPECT_EQ(bench.device.counters().link.duplicates, 0u);
  // The device is in step afterwards, and the request that ran before is still the cached one.
  EXPECT_EQ(bench.exchange(request("c[10,20]", 1)), response('c', "[0]", 1));
  EXPECT_EQ(runs, 1);
  EXPECT_EQ(bench.exchange(request("a", 3)), response('a', "[0]", 3));
  EXPECT_EQ(runs, 2);
}

TEST(BasicRomiSerial, TheLongestPayloadFitsWhatRomiSerialRejects) {
  // RomiSerial's own limit, for comparison: 58 fits, 59 is too long (the same check, another size).
  fake_now = 0;
  Bench<BenchDevice> bench;
  const std::string longest = "d[\"0123456789abcdefghijklmnopqrstuv\"]";
  ASSERT_EQ(longest.size(), 37u);
  EXPECT_EQ(bench.exchange(request(longest, 4)), response('d', "[0]", 4));
  EXPECT_EQ(last_string, "0123456789abcdefghijklmnopqrstuv");
  EXPECT_EQ(bench.exchange(request(longest, 4)), response('d', "[0]", 4));  // a re-send: from the cache
  EXPECT_EQ(bench.device.counters().link.duplicates, 1u);
  // One character more (the parser's -11 on RomiSerial) is too long for this device.
  const std::string longer = "d[\"0123456789abcdefghijklmnopqrstuvw\"]";
  EXPECT_EQ(bench.exchange(request(longer, 5)), response('d', "[-1]", 0));
  Bench<RomiSerial> full;
  EXPECT_EQ(full.exchange(request(longer, 5)), response('d', "[-11]", 5));
}

TEST(BasicRomiSerial, AReplyLongerThanItsReplyCapacityIsAnsweredMinus31) {
  fake_now = 0;
  static std::string body;
  const MessageHandler handlers[] = {{'q', 0, false, [](IRomiSerial* romi, int16_t*, const char*) {
                                        romi->send(body.c_str());
                                      }}};
  Bench<BasicRomiSerial<4, 20>> bench;
  bench.device.set_handlers(handlers, 1);
  body = "[0,1234567]";  // 11 + 9 = 20 bytes: fits exactly
  EXPECT_EQ(bench.exchange(request("q", 1)), response('q', body, 1));
  EXPECT_EQ(bench.exchange(request("q", 1)), response('q', body, 1));  // cached whole
  body += "9";
  EXPECT_EQ(bench.exchange(request("q", 2)), response('q', "[-31]", 2));
  EXPECT_EQ(bench.exchange(request("q", 2)), response('q', "[-31]", 2));  // remembered like a reply
  EXPECT_EQ(bench.exchange("#q:xxxx\r\n"), response('q', "[-31]", 0));    // manual: not cached, same
  EXPECT_EQ(bench.device.counters().replies_too_long, 2u);
  EXPECT_EQ(bench.device.counters().executed, 3u);
  // send_error's text is formed first, then held against the device's capacity.
  const MessageHandler errors[] = {{'f', 0, false, fail}, {'x', 0, false, error_without_message}};
  bench.device.set_handlers(errors, 2);
  EXPECT_EQ(bench.exchange(request("f", 3)), response('f', "[-31]", 3));
  EXPECT_EQ(bench.exchange(request("x", 4)), response('x', "[3]", 4));
  EXPECT_EQ(bench.device.counters().replies_too_long, 3u);
}

TEST(BasicRomiSerial, DevicesOfDifferentSizesWorkSideBySide) {
  fake_now = 0;
  runs = 0;
  Bench<RomiSerial> full;
  Bench<BenchDevice> bench;
  Bench<SmallestDevice> smallest;
  Bench<BasicRomiSerial<8, 16>> small;
  RomiSerialBase* const devices[] = {&full.device, &bench.device, &smallest.device, &small.device};
  // The same request with the same id to each: every one runs it once and caches its own reply.
  const std::string a = request("a", 9);
  EXPECT_EQ(full.exchange(a), response('a', "[0]", 9));
  EXPECT_EQ(bench.exchange(a), response('a', "[0]", 9));
  EXPECT_EQ(smallest.exchange(a), response('a', "[0]", 9));
  EXPECT_EQ(small.exchange(a), response('a', "[0]", 9));
  EXPECT_EQ(runs, 4);
  // What fits one device and not the next, interleaved: each answers from its own buffers.
  const std::string c = request("c[100,200]", 10);  // 10 characters
  EXPECT_EQ(small.exchange(c), response('c', "[-1]", 0));
  EXPECT_EQ(smallest.exchange(c), response('c', "[-1]", 0));
  EXPECT_EQ(bench.exchange(c), response('c', "[0]", 10));
  EXPECT_EQ(full.exchange(c), response('c', "[0]", 10));
  const std::string e = request("e", 11);  // a 16-byte reply
  EXPECT_EQ(smallest.exchange(e), response('e', "[-31]", 11));
  EXPECT_EQ(small.exchange(e), response('e', "[0,1,2]", 11));
  EXPECT_EQ(bench.exchange(e), response('e', "[0,1,2]", 11));
  // Re-sends: each device repeats its own last reply and none runs a handler again.
  const int before = runs;
  EXPECT_EQ(smallest.exchange(e), response('e', "[-31]", 11));
  EXPECT_EQ(small.exchange(e), response('e', "[0,1,2]", 11));
  EXPECT_EQ(bench.exchange(e), response('e', "[0,1,2]", 11));
  EXPECT_EQ(full.exchange(c), response('c', "[0]", 10));
  EXPECT_EQ(runs, before);
  // One function serves every size (RomiSerialBase): the capacities are the device's.
  const uint8_t payloads[] = {58, 37, 1, 8};
  const uint8_t replies[] = {72, 16, 14, 16};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(devices[i]->payload_capacity(), payloads[i]) << i;
    EXPECT_EQ(devices[i]->reply_capacity(), replies[i]) << i;
    EXPECT_EQ(devices[i]->counters().link.duplicates, 1u) << i;  // its own re-send
  }
}

TEST(BasicRomiSerial, TheSmallestDeviceTakesBareOpcodesAndAnswersEveryProtocolCode) {
  fake_now = 0;
  runs = 0;
  Bench<SmallestDevice> bench;
  EXPECT_EQ(bench.exchange("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(bench.exchange(request("a", 1)), response('a', "[0]", 1));
  EXPECT_EQ(bench.exchange(request("a", 1)), response('a', "[0]", 1));  // exactly once, 1-byte key
  EXPECT_EQ(runs, 2);
  EXPECT_EQ(bench.exchange(request("b", 2)), response('b', "[-20]", 2));  // silent handler
  EXPECT_EQ(bench.exchange(request("z", 3)), response('z', "[-16]", 3));
  EXPECT_EQ(bench.exchange(request("d", 4)), response('d', "[-18]", 4));
  EXPECT_EQ(bench.exchange(request("%", 5)), response('_', "[-14]", 5));
  EXPECT_EQ(bench.exchange(request("e", 6)), response('e', "[-31]", 6));   // "[0,1,2]" needs 16
  EXPECT_EQ(bench.exchange(request("c[1,2]", 7)), response('c', "[-1]", 0));  // arguments: too long
  EXPECT_EQ(bench.exchange("#!hello:xxxx\r\n"), response('_', "[-1]", 0));
  EXPECT_EQ(bench.exchange("#!:xxxx\r\n"), response('_', "[-14]", 0));  // an empty log line fits
  EXPECT_EQ(bench.exchange("#a:7b00\r\n"), response('a', "[-4]", 0x7b));
  bench.exchange("#a");
  fake_now = 1000;
  EXPECT_EQ(bench.exchange(""), response('a', "[-30]", 0));
  EXPECT_EQ(bench.exchange(request("g", 8)), "#!first:xxxx\r\n#!multi  line: yes:xxxx\r\n" + response('g', "[0]", 8));
  EXPECT_EQ(bench.device.counters().link.oversize_frames, 2u);
}

// The request deadline and the cache's lifetime are checked when the clock moved since the last check,
// which the device reads once per handle_input and once after each handler: a slow manual request may
// outlive the cached reply of an earlier request, whose re-send must then run.
TEST_F(RomiSerialTest, TheCacheExpiresDuringASlowManualRequest) {
  fake_now = 0;
  EXPECT_EQ(exchange(request("a", 5)), response('a', "[0]", 5));
  fake_now = 1800;
  EXPECT_EQ(exchange("#w:xxxx\r\n"), response('w', "[0]", 0));  // its handler answers at 2300
  EXPECT_EQ(fake_now, 2300u);
  EXPECT_EQ(exchange(request("a", 5)), response('a', "[0]", 5));  // same millisecond: no cache any more
  EXPECT_EQ(runs, 3);
  EXPECT_EQ(device.counters().link.duplicates, 0u);
  // And in one batch: the re-send queued behind the slow manual request runs too.
  fake_now = 4000;
  EXPECT_EQ(exchange(request("a", 6)), response('a', "[0]", 6));
  fake_now = 5800;
  EXPECT_EQ(exchange("#w:xxxx\r\n" + request("a", 6)), response('w', "[0]", 0) + response('a', "[0]", 6));
  EXPECT_EQ(runs, 6);
}

TEST(BasicRomiSerialFreshState, ASizedDeviceBuiltOverUsedMemoryStartsFresh) {
  // Its buffers are not cleared (the device writes them before reading them): garbage there is harmless.
  alignas(BenchDevice) unsigned char storage[sizeof(BenchDevice)];
  std::memset(storage, 0xa5, sizeof storage);
  StringStreams streams;
  fake_now = 0;
  runs = 0;
  BenchDevice* device = new (storage) BenchDevice(streams, streams, kHandlers, kHandlerCount, fake_clock);
  const std::string first = request("a", 0xa5);
  streams.input.assign(first.begin(), first.end());
  device->handle_input();
  EXPECT_EQ(streams.take(), response('a', "[0]", 0xa5));
  EXPECT_EQ(runs, 1);
  device->~BenchDevice();
}

// --- ArrayText -----------------------------------------------------------------------------------------

TEST(ArrayText, BuildsArrays) {
  ArrayText<32> text;
  EXPECT_STREQ(text.c_str(), "[]");
  text.add_int(0).add_int(-32768).add_int(1023).add_string("hi");
  EXPECT_STREQ(text.c_str(), "[0,-32768,1023,\"hi\"]");
  EXPECT_TRUE(text.ok());
  EXPECT_EQ(text.size(), 20u);
  text.clear();
  text.add_int(INT32_MIN).add_int(INT32_MAX);
  EXPECT_STREQ(text.c_str(), "[-2147483648,2147483647]");
}

// format_decimal forms digits by subtraction, 32-bit above 65535 and 16-bit below: the values around
// each power of ten and around the switch between the two must come out as printf writes them.
TEST(ArrayText, FormatDecimalMatchesPrintfAtEveryPowerOfTenAndTheSixteenBitBoundary) {
  std::vector<int64_t> values = {0, INT32_MIN, INT32_MAX, 65535, 65536, 99999, 100000, 655350, 4294967};
  for (int64_t power = 1; power <= 1000000000; power *= 10) {
    for (int64_t delta = -1; delta <= 1; ++delta) values.push_back(power + delta);
  }
  for (int32_t v = -70000; v <= 70000; v += 7) values.push_back(v);
  for (const int64_t wide : values) {
    for (const int64_t signed_value : {wide, -wide}) {
      if (signed_value < INT32_MIN || signed_value > INT32_MAX) continue;
      const auto value = static_cast<int32_t>(signed_value);
      char expected[16];
      std::snprintf(expected, sizeof expected, "%ld", static_cast<long>(value));
      char out[12];
      const uint8_t length = tether::romi::device::format_decimal(value, out);
      ASSERT_EQ(std::string(out, length), expected) << value;
    }
  }
}

TEST(ArrayText, OverflowKeepsAValidArray) {
  ArrayText<8> text;  // "[12345]" + NUL fits exactly
  text.add_int(12345);
  EXPECT_STREQ(text.c_str(), "[12345]");
  EXPECT_TRUE(text.ok());
  text.add_int(1);
  EXPECT_STREQ(text.c_str(), "[12345]");
  EXPECT_FALSE(text.ok());
  ArrayText<6> small;
  small.add_string("abc");  // "[\"abc\"]" needs 8
  EXPECT_STREQ(small.c_str(), "[]");
  EXPECT_FALSE(small.ok());
  small.clear();
  small.add_string(nullptr);
  EXPECT_STREQ(small.c_str(), "[\"\"]");
}

}  // namespace
