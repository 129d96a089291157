// The double must reproduce the reference's published vectors and defects, or tests against it prove
// nothing about the field.
#include "reference_firmware_double.hpp"

#include <gtest/gtest.h>

#include "tether/romi/encoder.hpp"

namespace tether::romi::testing {
namespace {

ReferenceFirmwareDouble reference_test_firmware() {
  return ReferenceFirmwareDouble({
      {'a', 0, false, [](auto&, auto&) { return std::string("[0]"); }},
      {'c', 2, false, [](auto&, auto&) { return std::string("[0]"); }},
      {'d', 0, true, [](auto&, auto&) { return std::string("[0]"); }},
      {'e', 0, false, [](auto&, auto&) { return std::string("[0,1,2]"); }},
      {'f', 0, false, [](auto&, auto&) { return std::string("[101,\"I will try again tomorrow\"]"); }},
      {'b', 0, false, [](auto&, auto&) { return std::string(); }},
  });
}

TEST(ReferenceFirmwareDouble, PublishedVectors) {
  auto firmware = reference_test_firmware();
  EXPECT_EQ(firmware.feed("#a:xxxx\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(firmware.feed("#e:xxxx\r\n"), "#e[0,1,2]:00dc\r\n");
  EXPECT_EQ(firmware.feed("#f:32dd\r\n"), "#f[101,\"I will try again tomorrow\"]:32c3\r\n");
  EXPECT_EQ(firmware.feed("#a[1]:xxxx\r\n"), "#a[-17]:00ac\r\n");
  EXPECT_EQ(firmware.feed("#z:xxxx\r\n"), "#z[-16]:0001\r\n");
}

TEST(ReferenceFirmwareDouble, DuplicateIdIsRefusedAndNotExecuted) {
  auto firmware = reference_test_firmware();
  EXPECT_EQ(firmware.feed("#a:008e\r\n"), "#a[0]:00e7\r\n");
  EXPECT_EQ(firmware.feed("#a:008e\r\n").substr(0, 7), "#a[-15]");
  EXPECT_EQ(firmware.executions('a'), 1);
}

TEST(ReferenceFirmwareDouble, FreshFirmwareRefusesId255) {
  auto firmware = reference_test_firmware();
  uint8_t frame[32];
  const auto size = encode_request(ByteView::from_literal("a"), 255, frame);
  EXPECT_EQ(firmware.feed(std::string(reinterpret_cast<char*>(frame), size.value())).substr(0, 7), "#a[-15]");
}

TEST(ReferenceFirmwareDouble, FiftyEightCharacterPayloadIsAnsweredTwice) {
  auto firmware = reference_test_firmware();
  const std::string payload = "c[" + std::string(55, '1') + "]";
  uint8_t frame[128];
  const auto size = encode_request(ByteView::from_chars(payload.data(), payload.size()), 3, frame);
  const std::string answer = firmware.feed(std::string(reinterpret_cast<char*>(frame), size.value()));
  EXPECT_NE(answer.find("[-1]"), std::string::npos);
  EXPECT_NE(answer.find("#c[0]:03"), std::string::npos);
  EXPECT_EQ(firmware.executions('c'), 0);
}

TEST(ReferenceFirmwareDouble, ErrorRepliesEchoTheLastGoodOpcode) {
  auto firmware = reference_test_firmware();
  firmware.feed("#e:xxxx\r\n");
  EXPECT_EQ(firmware.feed("#a\r\n").substr(0, 6), "#e[-6]");
  EXPECT_EQ(firmware.feed("#b:xxxx\r\n").substr(0, 7), "#b[-20]");
}

}  // namespace
}  // namespace tether::romi::testing
