// The rpc device runtime against its wire behaviour (rpc_device.hpp), on the arm schema's nanopb structs,
// with a hand-written service table (the shape `tether generate` writes) and a fake clock.
#include "tether/rpc/device/rpc_device.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "arm.pb.h"
#include "tether/rpc/schema.hpp"
#include "tether_rpc.pb.h"
#include "wire.hpp"

// The arm schema's encoders and decoders, as the generated service code has them.
TETHER_RPC_MESSAGE_DECLARE(arm_JointRequest)
TETHER_RPC_MESSAGE_DECLARE(arm_JointReply)
TETHER_RPC_MESSAGE_DECLARE(arm_StateRequest)
TETHER_RPC_MESSAGE_DECLARE(arm_State)
TETHER_RPC_MESSAGE_DEFINE(arm_JointRequest)
TETHER_RPC_MESSAGE_DEFINE(arm_JointReply)
TETHER_RPC_MESSAGE_DEFINE(arm_StateRequest)
TETHER_RPC_MESSAGE_DEFINE(arm_State)

namespace {

using tether::Millis;
using tether::proxy::Integrity;
using tether::rpc::DeviceErrorCode;
using tether::rpc::Status;
using wire::Bytes;

// The application: records what it was asked, answers what the test says.
struct Application {
  int moves = 0;
  arm_JointRequest last_move = arm_JointRequest_init_zero;
  Status move_status = Status::ok();
  int extra_angles = 0;  // JointReply has one field: a large reply comes from Watch
  int watches = 0;
  Status watch_status = Status::ok();
  uint32_t angle_count = 2;
};
Application app;

Status arm_MoveJoint(const void* request, void* reply) {
  const auto& in = *static_cast<const arm_JointRequest*>(request);
  auto& out = *static_cast<arm_JointReply*>(reply);
  ++app.moves;
  app.last_move = in;
  if (!app.move_status.is_ok()) return app.move_status;
  out.reached_cdeg = in.angle_cdeg - 1;
  return Status::ok();
}

Status arm_Watch(const void*, void* reply) {
  auto& out = *static_cast<arm_State*>(reply);
  ++app.watches;
  if (!app.watch_status.is_ok()) return app.watch_status;
  out.angles_cdeg_count = static_cast<pb_size_t>(app.angle_count);
  for (pb_size_t i = 0; i < out.angles_cdeg_count; ++i) out.angles_cdeg[i] = -2000000000 + static_cast<int32_t>(i);
  out.millis = static_cast<uint32_t>(app.watches);
  return Status::ok();
}

// The arm schema's two methods, and a third entry streaming the same handler, so that two methods compete
// for TestLimits' one stream slot.
const tether::rpc::device::Method kMethods[] = {
    {&tether_rpc_decode_arm_JointRequest, &tether_rpc_encode_arm_JointReply, &arm_MoveJoint, false},
    {&tether_rpc_decode_arm_StateRequest, &tether_rpc_encode_arm_State, &arm_Watch, true},
    {&tether_rpc_decode_arm_StateRequest, &tether_rpc_encode_arm_State, &arm_Watch, true},
};

union Requests {
  arm_JointRequest move;
  arm_StateRequest watch;
};
union Replies {
  arm_JointReply move;
  arm_State watch;
};

std::uint64_t arm_hash() {
  return tether::rpc::Schema::load(std::string(TETHER_RPC_TEST_SCHEMAS) + "/arm.proto").hash();
}

// Small tables, so that the limits are reached in a few messages.
struct TestLimits {
  static constexpr size_t kMaxPayload = 80;
  static constexpr uint8_t kStreams = 1;
  static constexpr uint8_t kStreamRequestBytes = 4;
  static constexpr uint8_t kDuplicateDepth = 2;
  static constexpr uint16_t kReplyCacheBytes = 72;
  static constexpr size_t kMaxOutPayload = 72;
  static constexpr size_t kRequestStructBytes = sizeof(Requests);
  static constexpr size_t kReplyStructBytes = sizeof(Replies);
};

// The same tables, the answer buffers in static RAM (as the Arduino libraries keep them).
struct StaticTestLimits : TestLimits {
  static constexpr bool kStaticBuffers = true;
};

// A device's answer, decoded; the Reply / StreamMessage payload kept as bytes.
struct Answer {
  tether_rpc_wire_DeviceMessage message;
  Bytes payload;
};

// A Reply's or StreamMessage's bytes field for nanopb's encoder: `arg` is the Bytes.
bool encode_bytes(pb_ostream_t* stream, const pb_field_t* field, void* const* arg) {
  const Bytes& bytes = *static_cast<const Bytes*>(*arg);
  return pb_encode_tag_for_field(stream, field) && pb_encode_string(stream, bytes.data(), bytes.size());
}

// nanopb's encoding of `answer` (the device writes its answers by hand: they must be these bytes).
Bytes nanopb_encoding(Answer answer) {
  if (answer.message.which_body == tether_rpc_wire_DeviceMessage_reply_tag) {
    answer.message.body.reply.reply.funcs.encode = &encode_bytes;
    answer.message.body.reply.reply.arg = &answer.payload;
  } else if (answer.message.which_body == tether_rpc_wire_DeviceMessage_stream_tag) {
    answer.message.body.stream.message.funcs.encode = &encode_bytes;
    answer.message.body.stream.message.arg = &answer.payload;
  }
  return wire::encode(tether_rpc_wire_DeviceMessage_fields, &answer.message);
}

// The bytes of field `inner` inside length-delimited field `outer` of `payload` (a Reply's reply, a
// StreamMessage's message); nanopb skips callback fields it has no callback for.
Bytes nested_bytes(const tether::ByteView payload, uint32_t outer, uint32_t inner) {
  pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
  pb_wire_type_t type;
  uint32_t tag;
  bool eof;
  while (pb_decode_tag(&stream, &type, &tag, &eof)) {
    if (tag == outer && type == PB_WT_STRING) {
      pb_istream_t body;
      if (!pb_make_string_substream(&stream, &body)) break;
      while (pb_decode_tag(&body, &type, &tag, &eof)) {
        if (tag == inner && type == PB_WT_STRING) {
          pb_istream_t bytes;
          if (!pb_make_string_substream(&body, &bytes)) break;
          Bytes out(bytes.bytes_left);
          if (!pb_read(&bytes, out.data(), out.size())) break;
          return out;
        }
        if (!pb_skip_field(&body, type)) break;
      }
      break;
    }
    if (!pb_skip_field(&stream, type)) break;
  }
  ADD_FAILURE() << "no field " << inner << " in field " << outer;
  return {};
}

// Each test runs on a device made with its bindings and on one made without arguments (all zeros: how the
// images keep theirs in .bss) and bound afterwards.
class RpcDevice : public ::testing::TestWithParam<bool> {
 protected:
  using Device = tether::rpc::device::Device<TestLimits>;
  RpcDevice() {
    app = Application{};
    service_.schema_hash = hash_;
    device_.set_min_period_ms(5);
    device_.begin(0xC0FFEE, now_);
  }

  static tether::rpc::device::Service make_service() {
    return tether::rpc::device::Service{0, kMethods, 3};
  }

  // Sends `message` as one frame (fed in one run, or byte by byte) and returns what the device answered.
  std::vector<Answer> send(const tether_rpc_wire_HostMessage& message, bool byte_by_byte = false) {
    return send_payload(wire::encode(tether_rpc_wire_HostMessage_fields, &message), byte_by_byte);
  }
  std::vector<Answer> send_payload(const Bytes& payload, bool byte_by_byte = false) {
    recorder_.clear();
    const Bytes frame = wire::frame(payload, Integrity::crc16);
    if (byte_by_byte) {
      for (const uint8_t byte : frame) device_.handle_byte(byte, now_);
    } else {
      size_t used = 0;
      while (used < frame.size()) {
        used += device_.handle_bytes(tether::ByteView(frame.data() + used, frame.size() - used), now_);
      }
    }
    return answers();
  }
  std::vector<Answer> poll_at(Millis at) {
    recorder_.clear();
    now_ = at;
    device_.poll(now_);
    return answers();
  }
  // Every frame the device wrote since the last clear, decoded.
  std::vector<Answer> answers() const {
    std::vector<Answer> out;
    for (const Bytes& frame : recorder_.frames) {
      tether::LinkCounters counters;
      tether::proxy::Decoder<128> decoder(Integrity::crc16, counters);
      size_t used = 0;
      tether::DecodeStatus status = tether::DecodeStatus::more;
      while (used < frame.size() && status == tether::DecodeStatus::more) {
        const auto fed = decoder.feed(tether::ByteView(frame.data() + used, frame.size() - used));
        used += fed.consumed;
        status = fed.status;
      }
      EXPECT_EQ(status, tether::DecodeStatus::frame);
      EXPECT_EQ(used, frame.size());
      out.emplace_back();
      Answer& answer = out.back();
      answer.message = tether_rpc_wire_DeviceMessage_init_zero;
      pb_istream_t stream = pb_istream_from_buffer(decoder.frame().data(), decoder.frame().size());
      EXPECT_TRUE(pb_decode(&stream, tether_rpc_wire_DeviceMessage_fields, &answer.message));
      if (answer.message.which_body == tether_rpc_wire_DeviceMessage_reply_tag) {
        answer.payload = nested_bytes(decoder.frame(), tether_rpc_wire_DeviceMessage_reply_tag, tether_rpc_wire_Reply_reply_tag);
      } else if (answer.message.which_body == tether_rpc_wire_DeviceMessage_stream_tag) {
        answer.payload =
            nested_bytes(decoder.frame(), tether_rpc_wire_DeviceMessage_stream_tag, tether_rpc_wire_StreamMessage_message_tag);
      }
      EXPECT_EQ(Bytes(decoder.frame().begin(), decoder.frame().end()), nanopb_encoding(answer))
          << "an answer's bytes differ from nanopb's";
    }
    return out;
  }

  static tether_rpc_wire_HostMessage call(uint32_t id, uint32_t method, const Bytes& request) {
    tether_rpc_wire_HostMessage m = tether_rpc_wire_HostMessage_init_zero;
    m.id = id;
    m.which_body = tether_rpc_wire_HostMessage_call_tag;
    m.body.call.method = method;
    m.body.call.request.size = static_cast<pb_size_t>(request.size());
    if (!request.empty()) std::memcpy(m.body.call.request.bytes, request.data(), request.size());
    return m;
  }
  static tether_rpc_wire_HostMessage move(uint32_t id, uint32_t joint, int32_t angle) {
    arm_JointRequest request = arm_JointRequest_init_zero;
    request.joint = joint;
    request.angle_cdeg = angle;
    return call(id, 0, wire::encode(arm_JointRequest_fields, &request));
  }
  static tether_rpc_wire_HostMessage open(uint32_t id, uint32_t method, uint32_t period, const Bytes& request = {}) {
    tether_rpc_wire_HostMessage m = tether_rpc_wire_HostMessage_init_zero;
    m.id = id;
    m.which_body = tether_rpc_wire_HostMessage_open_tag;
    m.body.open.method = method;
    m.body.open.period_ms = period;
    m.body.open.request.size = static_cast<pb_size_t>(request.size());
    if (!request.empty()) std::memcpy(m.body.open.request.bytes, request.data(), request.size());
    return m;
  }
  static tether_rpc_wire_HostMessage bare(uint32_t id, pb_size_t which) {
    tether_rpc_wire_HostMessage m = tether_rpc_wire_HostMessage_init_zero;
    m.id = id;
    m.which_body = which;
    return m;
  }

  static void expect_ack(const Answer& answer, uint32_t id, bool refused) {
    ASSERT_EQ(answer.message.which_body, tether_rpc_wire_DeviceMessage_ack_tag);
    EXPECT_EQ(answer.message.body.ack.id, id);
    EXPECT_EQ(answer.message.body.ack.refused, refused);
  }
  static void expect_error(const Answer& answer, uint32_t call, uint32_t code, const std::string& text) {
    ASSERT_EQ(answer.message.which_body, tether_rpc_wire_DeviceMessage_error_tag);
    EXPECT_EQ(answer.message.body.error.call, call);
    EXPECT_EQ(answer.message.body.error.code, code);
    EXPECT_EQ(std::string(answer.message.body.error.text), text);
  }
  static void expect_refusal(const std::vector<Answer>& answers, uint32_t id, DeviceErrorCode code,
                             const std::string& text) {
    ASSERT_EQ(answers.size(), 2u);
    expect_error(answers[0], id, static_cast<uint32_t>(code), text);
    expect_ack(answers[1], id, true);
  }
  template <typename Message>
  static Message decode_payload(const Answer& answer, const pb_msgdesc_t* fields) {
    Message message{};
    pb_istream_t stream = pb_istream_from_buffer(answer.payload.data(), answer.payload.size());
    EXPECT_TRUE(pb_decode(&stream, fields, &message));
    return message;
  }

  const std::uint64_t hash_ = arm_hash();
  tether::rpc::device::Service service_ = make_service();
  wire::Recorder recorder_;
  std::unique_ptr<Device> made_ = make_device();
  Device& device_ = *made_;
  Millis now_ = 1000;

 private:
  std::unique_ptr<Device> make_device() {
    if (!GetParam()) return std::make_unique<Device>(service_, recorder_.sink(), &wire::Recorder::restart, &recorder_);
    auto device = std::make_unique<Device>();
    device->bind(service_, recorder_.sink(), &wire::Recorder::restart, &recorder_);
    return device;
  }
};

INSTANTIATE_TEST_SUITE_P(Made, RpcDevice, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& made) {
                           return std::string(made.param ? "Bound" : "Constructed");
                         });

TEST_P(RpcDevice, BeginSendsResetEventAfterADelimiter) {
  ASSERT_EQ(recorder_.frames.size(), 1u);
  EXPECT_EQ(recorder_.frames[0][0], 0x00);  // flushes a half frame the host may hold from before
  const auto answers = this->answers();
  ASSERT_EQ(answers[0].message.which_body, tether_rpc_wire_DeviceMessage_reset_tag);
  EXPECT_EQ(answers[0].message.body.reset.session, 0xC0FFEEu);
  EXPECT_EQ(device_.session_id(), 0xC0FFEEu);
}

TEST_P(RpcDevice, HelloAnswersTheSchemaHashSessionAndSizes) {
  const auto answers = send(bare(7, tether_rpc_wire_HostMessage_hello_tag));
  ASSERT_EQ(answers.size(), 2u);
  ASSERT_EQ(answers[0].message.which_body, tether_rpc_wire_DeviceMessage_hello_tag);
  const auto& hello = answers[0].message.body.hello;
  EXPECT_EQ(hello.schema_hash, hash_);
  EXPECT_EQ(hello.session, 0xC0FFEEu);
  EXPECT_EQ(hello.max_payload, 80u);
  EXPECT_EQ(hello.methods, 3u);
  expect_ack(answers[1], 7, false);
}

TEST_P(RpcDevice, ACallRunsItsHandlerAndRepliesBeforeTheAck) {
  for (const bool byte_by_byte : {false, true}) {
    const uint32_t id = byte_by_byte ? 2 : 1;
    const auto answers = send(move(id, 2, -4500), byte_by_byte);
    ASSERT_EQ(answers.size(), 2u);
    ASSERT_EQ(answers[0].message.which_body, tether_rpc_wire_DeviceMessage_reply_tag);
    EXPECT_EQ(answers[0].message.body.reply.call, id);
    EXPECT_EQ(decode_payload<arm_JointReply>(answers[0], arm_JointReply_fields).reached_cdeg, -4501);
    expect_ack(answers[1], id, false);
    EXPECT_EQ(app.last_move.joint, 2u);
    EXPECT_EQ(app.last_move.angle_cdeg, -4500);
  }
  EXPECT_EQ(app.moves, 2);
  EXPECT_EQ(device_.counters().calls, 2u);
}

TEST_P(RpcDevice, AReSentCallGetsTheSameReplyWithoutRunningAgain) {
  const auto first = send(move(5, 1, 100));
  app.move_status = Status::error(9, "must not run");
  const auto again = send(move(5, 1, 100));
  EXPECT_EQ(app.moves, 1);
  ASSERT_EQ(again.size(), 2u);
  EXPECT_EQ(again[0].payload, first[0].payload);
  EXPECT_EQ(again[0].message.body.reply.call, 5u);
  expect_ack(again[1], 5, false);
  EXPECT_EQ(device_.counters().link.duplicates, 1u);
  // The same id with other bytes is a new call (a new host session restarted its ids).
  app.move_status = Status::ok();
  send(move(5, 1, 200));
  EXPECT_EQ(app.moves, 2);
}

TEST_P(RpcDevice, AHandlerErrorIsTheCallsAnswerAndIsRememberedLikeAReply) {
  app.move_status = Status::error(42, "joint 3 is locked");
  const auto answers = send(move(3, 3, 0));
  ASSERT_EQ(answers.size(), 2u);
  expect_error(answers[0], 3, 42, "joint 3 is locked");
  expect_ack(answers[1], 3, false);  // it ran: not a refusal
  const auto again = send(move(3, 3, 0));
  ASSERT_EQ(again.size(), 2u);
  expect_error(again[0], 3, 42, "joint 3 is locked");
  EXPECT_EQ(app.moves, 1);
  EXPECT_EQ(device_.counters().handler_errors, 1u);
  // Codes outside the application's range are sent as its last code.
  app.move_status = Status::error(0xFF01, "pretends to be Tether");
  expect_error(send(move(4, 3, 0))[0], 4, 0xFEFF, "pretends to be Tether");
}

// The cache keeps an answer's fields after its call id and rebuilds the rest: a re-send gets the first
// answer's bytes, whatever the answer (a reply, an error with the longest text, a text in flash, id 0).
TEST_P(RpcDevice, ReSentAnswersAreTheFirstOnesByteForByte) {
  static const char kInFlash[] TETHER_IN_FLASH = "kept in flash";
  const std::string longest(60, 'x');  // sent as its first 47 characters
  const Status statuses[] = {Status::ok(), Status::error(0xFEFF, longest.c_str()), Status::error_P(7, kInFlash)};
  uint32_t id = 0;  // 0 first: a call id proto3 leaves out
  for (const Status& status : statuses) {
    app.move_status = status;
    const auto first = send(move(id, 1, -2000000000));
    ASSERT_EQ(first.size(), 2u);
    app.move_status = Status::error(9, "must not run");
    const auto again = send(move(id, 1, -2000000000));
    ASSERT_EQ(again.size(), 2u);
    EXPECT_EQ(again[0].payload, first[0].payload) << "id " << id;
    expect_ack(again[1], id, false);
    ++id;
  }
  expect_error(send(move(2, 1, -2000000000))[0], 2, 7, "kept in flash");  // id 2's answer, from the cache
  EXPECT_EQ(app.moves, 3);  // each call ran once
  EXPECT_EQ(device_.counters().link.duplicates, 4u);
}

TEST_P(RpcDevice, RefusalsNameTheirCauseAndAreLookedAtAgainWhenReSent) {
  expect_refusal(send(call(10, 3, {})), 10, DeviceErrorCode::unknown_method, "unknown method");
  expect_refusal(send(call(10, 3, {})), 10, DeviceErrorCode::unknown_method, "unknown method");
  EXPECT_EQ(device_.counters().refused, 2u);
  EXPECT_EQ(device_.counters().link.duplicates, 0u);
  expect_refusal(send(call(11, 1, {})), 11, DeviceErrorCode::not_unary, "method streams: open a stream");
  expect_refusal(send(open(12, 0, 100)), 12, DeviceErrorCode::not_streaming, "method does not stream: call it");
  expect_refusal(send(call(13, 0, {0xFF, 0xFF})), 13, DeviceErrorCode::bad_request, "request does not decode");
  expect_refusal(send(open(14, 1, 4)), 14, DeviceErrorCode::period_too_short, "period too short");
  expect_refusal(send(open(15, 1, 100, Bytes(5, 0))), 15, DeviceErrorCode::request_too_large,
                 "stream request too large");
  expect_refusal(send(bare(16, 0)), 16, DeviceErrorCode::unknown_message, "unknown message");
  EXPECT_EQ(app.moves, 0);
  EXPECT_EQ(app.watches, 0);
}

TEST_P(RpcDevice, NotAHostMessageIsAnsweredWithoutAnAck) {
  const auto answers = send_payload(Bytes{0x0A, 0x05, 0x01});  // field 1 as a truncated length-delimited
  ASSERT_EQ(answers.size(), 1u);
  expect_error(answers[0], 0, static_cast<uint32_t>(DeviceErrorCode::bad_envelope), "not a HostMessage");
  EXPECT_EQ(device_.counters().decode_errors, 1u);
}

TEST_P(RpcDevice, AStreamSendsAMessagePerPeriodUntilClosed) {
  const auto opened = send(open(20, 1, 100));
  ASSERT_EQ(opened.size(), 1u);
  expect_ack(opened[0], 20, false);
  EXPECT_TRUE(device_.stream_open(20));
  EXPECT_EQ(device_.open_streams(), 1);
  const Millis opened_at = now_;
  for (uint32_t seq = 0; seq < 3; ++seq) {
    const auto due = poll_at(opened_at + seq * 100);
    ASSERT_EQ(due.size(), 1u) << seq;
    ASSERT_EQ(due[0].message.which_body, tether_rpc_wire_DeviceMessage_stream_tag);
    EXPECT_EQ(due[0].message.body.stream.stream, 20u);
    EXPECT_EQ(due[0].message.body.stream.seq, seq);
    const auto state = decode_payload<arm_State>(due[0], arm_State_fields);
    EXPECT_EQ(state.angles_cdeg_count, 2u);
    EXPECT_EQ(state.millis, seq + 1);
    EXPECT_TRUE(poll_at(opened_at + seq * 100 + 99).empty());
  }
  // Closing a stream that is not open is acked, and changes nothing.
  tether_rpc_wire_HostMessage close = bare(21, tether_rpc_wire_HostMessage_close_tag);
  close.body.close.stream = 99;
  expect_ack(send(close)[0], 21, false);
  EXPECT_TRUE(device_.stream_open(20));
  close = bare(22, tether_rpc_wire_HostMessage_close_tag);
  close.body.close.stream = 20;
  expect_ack(send(close)[0], 22, false);
  EXPECT_FALSE(device_.stream_open(20));
  EXPECT_EQ(device_.open_streams(), 0);
  EXPECT_TRUE(poll_at(now_ + 1000).empty());
  EXPECT_EQ(device_.counters().stream_messages, 3u);
}

// The loop polls after every byte in or out; a poll at the same millisecond as the last one does nothing,
// unless a frame was handled since (a stream opened then sends its first message at once).
TEST_P(RpcDevice, AStreamOpenedAfterAPollAtTheSameMillisecondStartsAtTheNextPoll) {
  EXPECT_TRUE(poll_at(now_).empty());
  const auto opened = send(open(20, 1, 100));
  ASSERT_EQ(opened.size(), 1u);
  expect_ack(opened[0], 20, false);
  const auto due = poll_at(now_);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].message.which_body, tether_rpc_wire_DeviceMessage_stream_tag);
  EXPECT_TRUE(poll_at(now_).empty());
  EXPECT_EQ(poll_at(now_ + 100).size(), 1u);
}

TEST_P(RpcDevice, ReopeningAMethodReplacesItsStreamAndAFullTableRefuses) {
  send(open(30, 1, 100));
  send(open(31, 1, 50));
  EXPECT_FALSE(device_.stream_open(30));
  EXPECT_TRUE(device_.stream_open(31));
  poll_at(now_);
  const auto next = poll_at(now_ + 50);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].message.body.stream.stream, 31u);
  EXPECT_EQ(next[0].message.body.stream.seq, 1u);
  expect_refusal(send(open(32, 2, 100)), 32, DeviceErrorCode::streams_full, "too many streams");
  EXPECT_TRUE(device_.stream_open(31));
}

TEST_P(RpcDevice, AStreamHandlerErrorOrAnOversizeMessageEndsTheStream) {
  send(open(40, 1, 100));
  app.watch_status = Status::error(7, "no sensor");
  auto due = poll_at(now_);
  ASSERT_EQ(due.size(), 1u);
  expect_error(due[0], 40, 7, "no sensor");
  EXPECT_FALSE(device_.stream_open(40));

  app.watch_status = Status::ok();
  app.angle_count = 8;  // 8 values of 5 bytes each: over the 72-byte answer
  send(open(41, 1, 100));
  due = poll_at(now_);
  ASSERT_EQ(due.size(), 1u);
  expect_error(due[0], 41, static_cast<uint32_t>(DeviceErrorCode::reply_too_large), "reply too large");
  EXPECT_FALSE(device_.stream_open(41));
  EXPECT_EQ(device_.counters().send_failures, 1u);
}

TEST_P(RpcDevice, PingSilenceClosesTheStreams) {
  send(open(50, 1, 1000));
  poll_at(now_ + 9000);
  send(bare(51, tether_rpc_wire_HostMessage_ping_tag));  // at 10000: 10 s from here on
  poll_at(now_ + 9999);
  EXPECT_TRUE(device_.stream_open(50));
  poll_at(now_ + 1);
  EXPECT_FALSE(device_.stream_open(50));
  EXPECT_EQ(device_.counters().link.failsafes, 1u);
}

TEST_P(RpcDevice, DeviceHelloEveryFiveSeconds) {
  auto answers = poll_at(now_ + 4999);
  EXPECT_TRUE(answers.empty());
  answers = poll_at(now_ + 1);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers[0].message.which_body, tether_rpc_wire_DeviceMessage_hello_tag);
  EXPECT_EQ(answers[0].message.body.hello.schema_hash, hash_);
}

TEST_P(RpcDevice, ResetAcksThenRestarts) {
  const auto answers = send(bare(60, tether_rpc_wire_HostMessage_reset_tag));
  ASSERT_EQ(answers.size(), 1u);
  expect_ack(answers[0], 60, false);
  EXPECT_EQ(recorder_.restarts, 1);
  EXPECT_EQ(recorder_.bytes_at_restart, recorder_.bytes.size());  // the ack left first
}

TEST_P(RpcDevice, AStalledFrameIsDroppedAtItsDeadline) {
  const tether_rpc_wire_HostMessage message = move(70, 1, 1);
  const Bytes frame = wire::frame(wire::encode(tether_rpc_wire_HostMessage_fields, &message), Integrity::crc16);
  device_.handle_bytes(tether::ByteView(frame.data(), 3), now_);
  poll_at(now_ + 100);
  EXPECT_EQ(device_.counters().link.partial_timeouts, 1u);
  recorder_.clear();
  size_t used = 0;
  while (used < frame.size()) used += device_.handle_bytes(tether::ByteView(frame.data() + used, frame.size() - used), now_);
  EXPECT_EQ(answers().size(), 2u);  // the next frame whole: handled
  EXPECT_EQ(app.moves, 1);
}

// A poll between deadlines returns at once (the earliest deadline is kept); every deadline still comes on
// its millisecond: a stalled frame's (armed mid-way, after polls), DeviceHello's, a stream's.
TEST_P(RpcDevice, PollsBetweenDeadlinesRunNothingAndEveryDeadlineComesOnTime) {
  const tether_rpc_wire_HostMessage message = move(71, 1, 1);
  const Bytes frame = wire::frame(wire::encode(tether_rpc_wire_HostMessage_fields, &message), Integrity::crc16);
  const Millis start = now_;
  for (Millis t = start; t < start + 10; ++t) EXPECT_TRUE(poll_at(t).empty());
  device_.handle_bytes(tether::ByteView(frame.data(), 3), now_);  // a frame starts at start + 9
  for (Millis t = start + 10; t < start + 109; ++t) poll_at(t);
  EXPECT_EQ(device_.counters().link.partial_timeouts, 0u);
  poll_at(start + 109);
  EXPECT_EQ(device_.counters().link.partial_timeouts, 1u);
  for (Millis t = start + 110; t < start + 5000; ++t) ASSERT_TRUE(poll_at(t).empty()) << t;
  const auto hello = poll_at(start + 5000);
  ASSERT_EQ(hello.size(), 1u);
  EXPECT_EQ(hello[0].message.which_body, tether_rpc_wire_DeviceMessage_hello_tag);
}


TEST_P(RpcDevice, AnswerBuffersInStaticRamAnswerByteForByteAsOnTheStack) {
  wire::Recorder recorder;
  tether::rpc::device::Device<StaticTestLimits> device(service_, recorder.sink(), &wire::Recorder::restart, &recorder);
  device.set_min_period_ms(5);
  device.begin(0xC0FFEE, now_);
  EXPECT_EQ(recorder.frames, recorder_.frames);  // ResetEvent
  const auto feed = [&](const tether_rpc_wire_HostMessage& message) {
    recorder.clear();
    const Bytes frame = wire::frame(wire::encode(tether_rpc_wire_HostMessage_fields, &message), Integrity::crc16);
    for (size_t used = 0; used < frame.size();) {
      used += device.handle_bytes(tether::ByteView(frame.data() + used, frame.size() - used), now_);
    }
  };
  // A hello, a call, its re-send (from the cache), a refusal, a stream and its messages.
  for (const auto& message : {bare(1, tether_rpc_wire_HostMessage_hello_tag), move(2, 2, -4500), move(2, 2, -4500),
                              call(3, 7, {}), open(4, 1, 20)}) {
    send(message);
    feed(message);
    EXPECT_EQ(recorder.frames, recorder_.frames) << message.id;
  }
  // Stream messages: the handler's content moves on with each run (the application's state), their frames'
  // sizes do not.
  for (const Millis at : {now_ + 20, now_ + 40}) {
    poll_at(at);
    recorder.clear();
    device.poll(at);
    ASSERT_EQ(recorder.frames.size(), recorder_.frames.size()) << at;
    ASSERT_FALSE(recorder_.frames.empty());
    for (size_t i = 0; i < recorder.frames.size(); ++i) EXPECT_EQ(recorder.frames[i].size(), recorder_.frames[i].size());
  }
  EXPECT_EQ(device.counters().calls, device_.counters().calls);
  EXPECT_EQ(device.counters().stream_messages, device_.counters().stream_messages);
}
}  // namespace
