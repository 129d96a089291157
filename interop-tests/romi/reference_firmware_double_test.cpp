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

// The last frame of what the firmware sent (after its diagnostic lines).
std::string last_frame(const std::string& out) {
  const std::size_t end_of_previous = out.rfind("\r\n#");
  return end_of_previous == std::string::npos ? out : out.substr(end_of_previous + 2);
}

TEST(ReferenceFirmwareDouble, ErrorRepliesEchoTheLastGoodOpcode) {
  auto firmware = reference_test_firmware();
  firmware.feed("#e:xxxx\r\n");
  EXPECT_EQ(last_frame(firmware.feed("#a\r\n")).substr(0, 6), "#e[-6]");
  EXPECT_EQ(firmware.feed("#b:xxxx\r\n").substr(0, 7), "#b[-20]");
}

TEST(ReferenceFirmwareDouble, DamagedIdIsAnsweredWithIdZeroAfterDiagnosticLines) {
  auto firmware = reference_test_firmware();
  firmware.feed("#e:xxxx\r\n");
  // `#e:5097` arriving as `#e:5o97`: four log lines (the offending byte among them), then -2 with id 00.
  const std::string out = firmware.feed("#e:5o97\r\n");
  EXPECT_EQ(out.substr(0, out.rfind("#e[-2]:00")), "#!error:xxxx\r\n#!o:xxxx\r\n#!-2:xxxx\r\n#!e:xxxx\r\n");
  EXPECT_EQ(last_frame(out).substr(0, 9), "#e[-2]:00");
  EXPECT_EQ(firmware.feed("#e:\r\n").find("#!\r:xxxx\r\n"), 14u);  // a CR as the offending byte
  EXPECT_EQ(firmware.executions('e'), 1);
}

}  // namespace
}  // namespace tether::romi::testing
