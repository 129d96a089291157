// The rpc row's rules for playing a recorded device (`tether replay --as-device`): requests matched
// without their ids, the ids of the device's messages made the live host's, pings acked, a message the
// recording lacks refused.
#include <gtest/gtest.h>

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tether/proxy/encoder.hpp"
#include "tether/rpc/errors.hpp"
#include "tether/rpc/plugin.hpp"
#include "tether_rpc.pb.h"

namespace tether::rpc {
namespace {

using Bytes = std::vector<std::uint8_t>;
using transports::ReplayRequest;

std::span<const std::uint8_t> view(const Bytes& bytes) { return {bytes.data(), bytes.size()}; }

Bytes frame_of(const google::protobuf::Message& message, bool leading) {
  const std::string payload = message.SerializeAsString();
  Bytes frame(proxy::max_frame_size(payload.size()));
  frame.resize(proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16,
                                   leading, MutableByteView(frame.data(), frame.size()))
                   .value());
  return frame;
}

Bytes call(std::uint32_t id, std::uint32_t method, const std::string& request) {
  wire::HostMessage message;
  message.set_id(id);
  message.mutable_call()->set_method(method);
  message.mutable_call()->set_request(request);
  return frame_of(message, true);
}

Bytes open_stream(std::uint32_t id) {
  wire::HostMessage message;
  message.set_id(id);
  message.mutable_open()->set_method(1);
  message.mutable_open()->set_period_ms(50);
  return frame_of(message, true);
}

Bytes ack(std::uint32_t id, bool refused = false) {
  wire::DeviceMessage message;
  message.mutable_ack()->set_id(id);
  message.mutable_ack()->set_refused(refused);
  return frame_of(message, false);
}

Bytes reply(std::uint32_t call, const std::string& bytes) {
  wire::DeviceMessage message;
  message.mutable_reply()->set_call(call);
  message.mutable_reply()->set_reply(bytes);
  return frame_of(message, false);
}

Bytes stream_message(std::uint32_t stream, std::uint32_t seq) {
  wire::DeviceMessage message;
  message.mutable_stream()->set_stream(stream);
  message.mutable_stream()->set_seq(seq);
  message.mutable_stream()->set_message("\x08\x01");
  return frame_of(message, false);
}

TEST(RpcReplay, CallsMatchWithoutTheirIdsAndAnswersCarryTheLiveIds) {
  const auto rules = capture_replayer();
  const Bytes recorded = call(4154106095u, 0, "\x08\x01\x10\xb8\x17");
  const Bytes live = call(12, 0, "\x08\x01\x10\xb8\x17");
  const ReplayRequest was = rules->classify(view(recorded));
  EXPECT_EQ(was.kind, ReplayRequest::Kind::request);
  EXPECT_EQ(rules->classify(view(live)).key, was.key);
  EXPECT_NE(rules->classify(view(call(12, 0, "\x08\x02"))).key, was.key);
  EXPECT_NE(rules->classify(view(call(12, 1, "\x08\x01\x10\xb8\x17"))).key, was.key);

  rules->matched(view(recorded), view(live));
  EXPECT_EQ(*rules->rewrite(view(reply(4154106095u, "\x08\xb8\x17"))), reply(12, "\x08\xb8\x17"));
  EXPECT_EQ(*rules->rewrite(view(ack(4154106095u))), ack(12));
  EXPECT_FALSE(rules->rewrite(view(ack(4154106094u))));  // a recorded ping's ack

  const Bytes opened = open_stream(744120740u);
  rules->matched(view(opened), view(open_stream(13)));
  EXPECT_EQ(*rules->rewrite(view(stream_message(744120740u, 2))), stream_message(13, 2));

  wire::DeviceMessage hello;
  hello.mutable_hello()->set_session(1217882823u);
  hello.mutable_hello()->set_schema_hash(0x67b6cac7908440c8u);
  const Bytes device_hello = frame_of(hello, false);
  EXPECT_EQ(*rules->rewrite(view(device_hello)), device_hello);
}

TEST(RpcReplay, PingsAreAckedAndWhatTheRecordingLacksIsRefused) {
  const auto rules = capture_replayer();
  wire::HostMessage ping;
  ping.set_id(21);
  ping.mutable_ping();
  const Bytes ping_frame = frame_of(ping, true);
  EXPECT_EQ(rules->classify(view(ping_frame)).kind, ReplayRequest::Kind::keepalive);
  const auto pong = rules->answer(view(ping_frame));
  ASSERT_EQ(pong.size(), 1u);
  EXPECT_EQ(pong[0], ack(21));

  const auto refused = rules->answer(view(call(22, 3, "")));
  ASSERT_EQ(refused.size(), 2u);
  wire::DeviceMessage error;
  error.mutable_error()->set_call(22);
  error.mutable_error()->set_code(static_cast<std::uint32_t>(DeviceErrorCode::unknown_method));
  error.mutable_error()->set_text("replay: not the recorded message");
  EXPECT_EQ(refused[0], frame_of(error, false));
  EXPECT_EQ(refused[1], ack(22, true));
}

}  // namespace
}  // namespace tether::rpc
