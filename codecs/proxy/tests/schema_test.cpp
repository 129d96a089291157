// The schemas against the spec's vectors: the deployed variant's messages encode to the published bytes
// (libprotobuf on the host), and the primary schema's worked example frame carries a ServoInit.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "rocketry.pb.h"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether_proxy.pb.h"

namespace tether::proxy {
namespace {

std::vector<uint8_t> bytes_of(const google::protobuf::Message& message) {
  const std::string text = message.SerializeAsString();
  return std::vector<uint8_t>(text.begin(), text.end());
}

TEST(ProxySchema, DeployedVariantHostMessagesMatchTheVectors) {
  RocketryProto::ArduinoIn servo_init;
  servo_init.mutable_servoinit()->set_pin(1823);
  servo_init.mutable_servoinit()->set_safeposition(1231);
  EXPECT_EQ(bytes_of(servo_init), (std::vector<uint8_t>{0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09}));
  RocketryProto::ArduinoIn servo_control;
  servo_control.mutable_servocontrol()->set_pin(5);
  servo_control.mutable_servocontrol()->set_position(180);
  EXPECT_EQ(bytes_of(servo_control), (std::vector<uint8_t>{0x12, 0x05, 0x08, 0x05, 0x10, 0xb4, 0x01}));
  RocketryProto::ArduinoIn digital;
  digital.mutable_digitalcontrol()->set_pin(13);
  digital.mutable_digitalcontrol()->set_activate(true);
  EXPECT_EQ(bytes_of(digital), (std::vector<uint8_t>{0x22, 0x04, 0x08, 0x0d, 0x10, 0x01}));
  RocketryProto::ArduinoIn reset;
  reset.mutable_reset();
  EXPECT_EQ(bytes_of(reset), (std::vector<uint8_t>{0x2a, 0x00}));
}

TEST(ProxySchema, DeployedVariantDeviceMessagesMatchTheVectors) {
  RocketryProto::ArduinoOut event;
  ASSERT_TRUE(event.ParseFromString(std::string("\x0a\x00", 2)));
  EXPECT_TRUE(event.has_eventmessage());
  EXPECT_EQ(event.eventmessage().type(), RocketryProto::RESET);
  RocketryProto::ArduinoOut error;
  ASSERT_TRUE(error.ParseFromString(std::string("\x12\x04\x08\x02\x10\x0d", 6)));
  EXPECT_EQ(error.errormessage().type(), RocketryProto::PIN_NOT_INITIALIZED);
  EXPECT_EQ(error.errormessage().data(), 13);
  RocketryProto::ArduinoOut state;
  ASSERT_TRUE(state.ParseFromString(std::string("\x22\x02\x08\x08", 4)));
  EXPECT_EQ(state.digitalstate().pin(), 8u);
  EXPECT_FALSE(state.digitalstate().activated());
}

TEST(ProxySchema, PrimaryMessagesRoundTripThroughAFrame) {
  tether::proxy::ArduinoIn in;
  in.set_messageid(0xDEADBEEF);
  in.mutable_servoinit()->set_pin(9);
  in.mutable_servoinit()->set_safeposition(90);
  const std::vector<uint8_t> payload = bytes_of(in);
  std::vector<uint8_t> wire(max_frame_size(payload.size()));
  const auto size = encode_frame(ByteView(payload.data(), payload.size()), Integrity::crc16, true,
                                 MutableByteView(wire.data(), wire.size()));
  ASSERT_TRUE(size.ok());
  LinkCounters counters;
  Decoder<64> decoder(Integrity::crc16, counters);
  tether::proxy::ArduinoIn decoded;
  for (std::size_t i = 0; i < size.value(); ++i) {
    if (decoder.feed(wire[i]) != DecodeStatus::frame) continue;
    ASSERT_TRUE(decoded.ParseFromArray(decoder.frame().data(), static_cast<int>(decoder.frame().size())));
  }
  EXPECT_EQ(decoded.messageid(), 0xDEADBEEFu);
  EXPECT_EQ(decoded.servoinit().safeposition(), 90);
}

}  // namespace
}  // namespace tether::proxy
