// The rules of the romi, proxy, proxy-compat and elcano rows (rpc's: its plugin's tests) for playing a
// recorded device (`tether replay --as-device`): which requests match (the fields the replay rewrites left
// out), the recorded answers rewritten for the live host (ids, CRCs), and what a request the recording
// lacks is answered.
#include <gtest/gtest.h>

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tether/devices/codecs.hpp"
#include "tether/proxy/client.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/romi/encoder.hpp"

namespace tether::devices {
namespace {

using Bytes = std::vector<std::uint8_t>;
using transports::ReplayRequest;

std::unique_ptr<transports::CaptureReplayer> replayer(std::string_view codec) {
  const CodecRow* row = find_codec(codec);
  EXPECT_NE(row, nullptr) << codec;
  if (row == nullptr || !row->capture_replay) return nullptr;
  DeviceConfig device;
  device.name = "dev";
  device.codec = row->codec;
  return row->capture_replay(device);
}

Bytes bytes_of(std::string_view text) { return Bytes(text.begin(), text.end()); }
std::string text_of(const Bytes& bytes) { return std::string(bytes.begin(), bytes.end()); }
std::span<const std::uint8_t> view(const Bytes& bytes) { return {bytes.data(), bytes.size()}; }

Bytes romi_request(std::string_view payload, std::uint8_t id) {
  Bytes frame(128);
  const auto written = romi::encode_request(ByteView::from_chars(payload.data(), payload.size()), id,
                                            MutableByteView(frame.data(), frame.size()));
  frame.resize(written.value());
  return frame;
}

Bytes romi_response(char opcode, std::string_view body, std::uint8_t id) {
  Bytes frame(128);
  const auto written = romi::encode_response(opcode, ByteView::from_chars(body.data(), body.size()), id,
                                             MutableByteView(frame.data(), frame.size()));
  frame.resize(written.value());
  return frame;
}

TEST(CaptureReplay, RomiMatchesOnThePayloadAndAnswersWithTheLiveIdAndItsCrc) {
  const auto rules = replayer("romi");
  ASSERT_TRUE(rules);
  const Bytes recorded = romi_request("a[1,2]", 0x05);
  const Bytes live = romi_request("a[1,2]", 0xc3);
  const ReplayRequest was = rules->classify(view(recorded));
  EXPECT_EQ(was.kind, ReplayRequest::Kind::request);
  EXPECT_EQ(was.key, "a[1,2]");
  EXPECT_EQ(rules->classify(view(live)).key, was.key);
  EXPECT_NE(rules->classify(view(romi_request("a[1,3]", 0x05))).key, was.key);
  EXPECT_EQ(rules->classify(view(bytes_of("#!hello:xxxx\r\n"))).kind, ReplayRequest::Kind::other);

  rules->matched(view(recorded), view(live));
  const auto answer = rules->rewrite(view(romi_response('a', "[0,7]", 0x05)));
  ASSERT_TRUE(answer);
  EXPECT_EQ(text_of(*answer), text_of(romi_response('a', "[0,7]", 0xc3)));
  // A log line as recorded; an answer to an id the live host never sent, not at all.
  EXPECT_EQ(text_of(*rules->rewrite(view(bytes_of("#!moving:xxxx\r\n")))), "#!moving:xxxx\r\n");
  EXPECT_FALSE(rules->rewrite(view(romi_response('a', "[0]", 0x06))));
  // A damaged recorded answer is played as it was.
  EXPECT_EQ(text_of(*rules->rewrite(view(bytes_of("#a[0]:05zz\r\n")))), "#a[0]:05zz\r\n");
}

TEST(CaptureReplay, RomiManualRequestsAreAnsweredWithIdZero) {
  const auto rules = replayer("romi");
  ASSERT_TRUE(rules);
  const Bytes manual = bytes_of("#e:xxxx\r\n");
  EXPECT_EQ(rules->classify(view(manual)).key, "e (manual)");
  const Bytes live = romi_request("e", 0x42);
  EXPECT_EQ(rules->classify(view(live)).key, "e");  // a manual request is not an ordinary one
  rules->matched(view(manual), view(manual));
  EXPECT_EQ(text_of(*rules->rewrite(view(romi_response('e', "[0,1]", 0)))), text_of(romi_response('e', "[0,1]", 0)));
}

TEST(CaptureReplay, RomiAnswersWhatTheRecordingLacksAsTheFirmwareAnswersAnUnknownOrDamagedRequest) {
  const auto rules = replayer("romi");
  ASSERT_TRUE(rules);
  const auto unknown = rules->answer(view(romi_request("z[4]", 0x11)));
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(text_of(unknown[0]), text_of(romi_response('z', "[-16]", 0x11)));
  const auto empty = rules->answer(view(bytes_of("#\r\n")));
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_EQ(text_of(empty[0]), "#_[-6]:007f\r\n");  // what the firmware answers the boot probe
  Bytes damaged = romi_request("e", 0x21);
  damaged[damaged.size() - 3] = damaged[damaged.size() - 3] == '0' ? '1' : '0';  // the CRC's last digit
  const auto crc = rules->answer(view(damaged));
  ASSERT_EQ(crc.size(), 1u);
  EXPECT_EQ(text_of(crc[0]), text_of(romi_response('e', "[-4]", 0x21)));
}

Bytes proxy_frame(const google::protobuf::Message& message, bool leading) {
  const std::string payload = message.SerializeAsString();
  Bytes frame(proxy::max_frame_size(payload.size()));
  const auto written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                           proxy::Integrity::crc16, leading, MutableByteView(frame.data(), frame.size()));
  frame.resize(written.value());
  return frame;
}

Bytes servo_control(std::uint32_t id, std::int32_t position) {
  proxy::ArduinoIn message;
  message.set_messageid(id);
  message.mutable_servocontrol()->set_pin(9);
  message.mutable_servocontrol()->set_position(position);
  return proxy_frame(message, true);
}

Bytes ack(std::uint32_t id, bool refused = false) {
  proxy::ArduinoOut message;
  message.mutable_ack()->set_messageid(id);
  message.mutable_ack()->set_refused(refused);
  return proxy_frame(message, false);
}

TEST(CaptureReplay, ProxyMatchesWithoutTheMessageIdAndAcksWithTheLiveId) {
  const auto rules = replayer("proxy");
  ASSERT_TRUE(rules);
  const Bytes recorded = servo_control(191224343, 120);
  const Bytes live = servo_control(7, 120);
  const ReplayRequest was = rules->classify(view(recorded));
  EXPECT_EQ(was.kind, ReplayRequest::Kind::request);
  EXPECT_EQ(was.key, "servoControl { pin: 9 position: 120 }");
  EXPECT_EQ(rules->classify(view(live)).key, was.key);
  EXPECT_NE(rules->classify(view(servo_control(7, 121))).key, was.key);

  rules->matched(view(recorded), view(live));
  // The ack with the live id, its CRC-16 and COBS redone; other messages as recorded.
  EXPECT_EQ(*rules->rewrite(view(ack(191224343))), ack(7));
  proxy::ArduinoOut reset;
  reset.mutable_resetevent()->set_sessionid(3389141521u);
  const Bytes reset_event = proxy_frame(reset, false);
  EXPECT_EQ(*rules->rewrite(view(reset_event)), reset_event);
  // The ack of a message the live host did not send (a recorded ping's): not sent.
  EXPECT_FALSE(rules->rewrite(view(ack(191224344))));
}

TEST(CaptureReplay, ProxyAcksPingsWheneverTheyComeAndRefusesWhatTheRecordingLacks) {
  const auto rules = replayer("proxy");
  ASSERT_TRUE(rules);
  proxy::ArduinoIn ping;
  ping.set_messageid(55);
  ping.mutable_ping();
  const Bytes ping_frame = proxy_frame(ping, true);
  EXPECT_EQ(rules->classify(view(ping_frame)).kind, ReplayRequest::Kind::keepalive);
  const auto pong = rules->answer(view(ping_frame));
  ASSERT_EQ(pong.size(), 1u);
  EXPECT_EQ(pong[0], ack(55));

  const auto refused = rules->answer(view(servo_control(56, 33)));
  ASSERT_EQ(refused.size(), 2u);
  proxy::ArduinoOut error;
  error.mutable_error()->set_text("replay: not the recorded message");
  EXPECT_EQ(refused[0], proxy_frame(error, false));
  EXPECT_EQ(refused[1], ack(56, true));

  Bytes damaged = servo_control(57, 33);
  damaged[3] ^= 0x01;
  EXPECT_EQ(rules->classify(view(damaged)).kind, ReplayRequest::Kind::other);
  EXPECT_TRUE(rules->answer(view(damaged)).empty());  // the device drops a frame whose CRC is wrong
}

TEST(CaptureReplay, ProxyCompatMatchesWholeMessagesAndPlaysAnswersAsRecorded) {
  const auto rules = replayer("proxy-compat");
  ASSERT_TRUE(rules);
  RocketryProto::ArduinoIn control;
  control.mutable_servocontrol()->set_pin(9);
  control.mutable_servocontrol()->set_position(45);
  const std::string payload = control.SerializeAsString();
  Bytes frame(proxy::max_frame_size(payload.size()));
  frame.resize(proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::none, true,
                                   MutableByteView(frame.data(), frame.size()))
                   .value());
  const ReplayRequest request = rules->classify(view(frame));
  EXPECT_EQ(request.kind, ReplayRequest::Kind::request);
  EXPECT_NE(request.key.find("position: 45"), std::string::npos) << request.key;
  const Bytes event = {0x03, 0x08, 0x01, 0x00};
  EXPECT_EQ(*rules->rewrite(view(event)), event);
  EXPECT_TRUE(rules->answer(view(frame)).empty());
}

TEST(CaptureReplay, ElcanoMatchesMessagesAsANodeForwardsThemAndPlaysAnswersAsRecorded) {
  const auto rules = replayer("elcano");
  ASSERT_TRUE(rules);
  const ReplayRequest drive = rules->classify(view(bytes_of("D{s 50}{a 25}\n")));
  EXPECT_EQ(drive.kind, ReplayRequest::Kind::request);
  EXPECT_EQ(rules->classify(view(bytes_of("D{s50}{a25}\n"))).key, drive.key);  // whitespace is no difference
  EXPECT_NE(rules->classify(view(bytes_of("D{s 51}{a 25}\n"))).key, drive.key);
  EXPECT_EQ(rules->classify(view(bytes_of("D{s}{a 25}\n"))).kind, ReplayRequest::Kind::other);  // damaged
  const Bytes sensor = bytes_of("S{s 69}{a -12}{b 432}{p 420,90210}\n");
  EXPECT_EQ(*rules->rewrite(view(sensor)), sensor);
  EXPECT_TRUE(rules->answer(view(bytes_of("D{s 1}{a 2}\n"))).empty());
}

}  // namespace
}  // namespace tether::devices
