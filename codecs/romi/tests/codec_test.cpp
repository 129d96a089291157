// Romi encoder, request builder and request parser: the published vectors and every error code.
#include <gtest/gtest.h>

#include <string>

#include "tether/romi/encoder.hpp"
#include "tether/romi/request_parser.hpp"

namespace tether::romi {
namespace {

ByteView view(const std::string& text) { return ByteView::from_chars(text.data(), text.size()); }

std::string request(const std::string& payload, uint8_t id) {
  uint8_t buffer[128];
  const auto size = encode_request(view(payload), id, buffer);
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(buffer), size.value());
}

std::string response(char opcode, const std::string& body, uint8_t id) {
  uint8_t buffer[128];
  const auto size = encode_response(opcode, view(body), id, buffer);
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(buffer), size.value());
}

TEST(RomiEncoder, PublishedRequestVectors) {
  EXPECT_EQ(request("e", 0x7b), "#e:7b04\r\n");
  EXPECT_EQ(request("M[16,\"Shutdown\"]", 0x7b), "#M[16,\"Shutdown\"]:7bba\r\n");
  // The reference host starting from id 255: its first two requests.
  EXPECT_EQ(request("a", 0), "#a:008e\r\n");
  EXPECT_EQ(request("a[1,2,3]", 0), "#a[1,2,3]:00dd\r\n");
}

TEST(RomiEncoder, PublishedResponseVectors) {
  EXPECT_EQ(response('e', "[0]", 0), "#e[0]:0092\r\n");
  EXPECT_EQ(response('e', "[0]", 0x7b), "#e[0]:7b40\r\n");
  EXPECT_EQ(response('M', "[1,\"Out of boundary\"]", 0x7b), "#M[1,\"Out of boundary\"]:7ba7\r\n");
  EXPECT_EQ(response('a', "[0]", 0), "#a[0]:00e7\r\n");
  EXPECT_EQ(response('a', "[-17]", 0), "#a[-17]:00ac\r\n");
  EXPECT_EQ(response('z', "[-16]", 0), "#z[-16]:0001\r\n");
  EXPECT_EQ(response('e', "[0,1,2]", 0), "#e[0,1,2]:00dc\r\n");
  EXPECT_EQ(response('f', "[101,\"I will try again tomorrow\"]", 0x32), "#f[101,\"I will try again tomorrow\"]:32c3\r\n");
}

TEST(RomiEncoder, ColonsInAResponseBodyBecomeDashes) {
  EXPECT_EQ(response('t', "[0,\"a:b\"]", 1).substr(0, 12), "#t[0,\"a-b\"]:");
}

TEST(RomiEncoder, ManualAndLogFrames) {
  uint8_t buffer[64];
  auto size = encode_manual_request(view("e[0]"), buffer);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(buffer), size.value()), "#e[0]:xxxx\r\n");
  size = encode_log(view("motor: 3 A\r\n"), buffer);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(buffer), size.value()), "#!motor: 3 A  :xxxx\r\n");
}

TEST(RomiEncoder, TooSmallBufferIsReportedNotOverrun) {
  uint8_t buffer[16] = {};
  buffer[8] = 0xAA;
  const auto size = encode_request(view("a[1,2,3]"), 0, MutableByteView(buffer, 8));
  EXPECT_EQ(size.status(), Status::buffer_too_small);
  EXPECT_EQ(buffer[8], 0xAA);
}

TEST(RomiRequestBuilder, BuildsPayloads) {
  EXPECT_TRUE(RequestBuilder('L').add_int(1).payload().equals(view("L[1]")));
  EXPECT_TRUE(RequestBuilder('M').add_int(16).add_string(view("Shutdown")).payload().equals(view("M[16,\"Shutdown\"]")));
  EXPECT_TRUE(RequestBuilder('s').add_int(-32768).add_int(32767).payload().equals(view("s[-32768,32767]")));
  EXPECT_TRUE(RequestBuilder('?').payload().equals(view("?")));
}

TEST(RomiRequestBuilder, RejectsBadInputWithTheProtocolsCodes) {
  EXPECT_EQ(RequestBuilder('#').error(), Error::invalid_opcode);
  EXPECT_EQ(RequestBuilder('a').add_int(40000).error(), Error::value_out_of_range);
  EXPECT_EQ(RequestBuilder('a').add_int(-32769).error(), Error::value_out_of_range);
  RequestBuilder thirteen('m');
  for (int i = 0; i < 13; ++i) thirteen.add_int(i);
  EXPECT_EQ(thirteen.error(), Error::too_many_arguments);
  EXPECT_EQ(RequestBuilder('t').add_string(view(std::string(33, 'a'))).error(), Error::string_too_long);
  EXPECT_EQ(RequestBuilder('t').add_string(view("a")).add_string(view("b")).error(), Error::too_many_strings);
  EXPECT_EQ(RequestBuilder('t').add_string(view("tab\there")).error(), Error::invalid_string);
  EXPECT_EQ(RequestBuilder('t').add_string(view("a:b")).error(), Error::reserved_character);
  EXPECT_EQ(RequestBuilder('t').add_string(view("a#b")).error(), Error::reserved_character);
  // 12 arguments of six characters and a 32-character string: more than a 64-byte frame can carry.
  RequestBuilder long_one('m');
  for (int i = 0; i < 12; ++i) long_one.add_int(-32768);
  EXPECT_EQ(long_one.error(), Error::client_request_too_long);
}

TEST(RomiRequestBuilder, LongestLegalRequestFitsSixtyFourBytes) {
  RequestBuilder builder('m');
  for (int i = 0; i < 7; ++i) builder.add_int(-32768);  // "m[" + 7*6 + 6 commas + "]" = 51
  builder.add_int(1);
  ASSERT_EQ(builder.error(), Error::no_error);
  uint8_t frame[128];
  EXPECT_LE(encode_request(builder.payload(), 0, frame).value(), kMaxRequestFrame);
}

TEST(RomiRequestBuilder, APayloadOfTheHostLimitBuildsAndOneCharacterMoreIsTooLong) {
  // An argument is written whole after one length check: the limit falls exactly where it did
  // when each character was checked, whichever argument reaches it, and a rejected one writes nothing.
  const auto build = [](int last, int arguments) {
    RequestBuilder builder('m');
    for (int i = 0; i + 1 < arguments; ++i) builder.add_int(-32768);
    builder.add_int(last);
    return builder;
  };
  // "m[", 7 x "-32768" and 7 separators: 51 characters; an eighth argument of 4 characters and the "]"
  // fill exactly kMaxHostPayload (56), one of 5 characters does not fit.
  const RequestBuilder exactly = build(-999, 8);
  ASSERT_EQ(exactly.error(), Error::no_error);
  EXPECT_EQ(exactly.payload().size(), kMaxHostPayload);
  EXPECT_TRUE(ByteView(exactly.payload().data() + kMaxHostPayload - 6, 6).equals(view(",-999]")));
  EXPECT_EQ(build(-9999, 8).error(), Error::client_request_too_long);
  EXPECT_EQ(build(1000, 8).error(), Error::no_error);  // "1000": four characters as well
  EXPECT_EQ(build(10000, 8).error(), Error::client_request_too_long);
  // Every digit count and sign, formatted as before.
  EXPECT_TRUE(RequestBuilder('a').add_int(0).add_int(9).add_int(-10).add_int(99).add_int(-100).add_int(999)
                  .add_int(1000).add_int(-9999).add_int(10000).add_int(-32768).payload()
                  .equals(view("a[0,9,-10,99,-100,999,1000,-9999,10000,-32768]")));
  // A string after integers, integers after a string: one bracket pair, separators between.
  EXPECT_TRUE(RequestBuilder('M').add_string(view("x")).add_int(7).payload().equals(view("M[\"x\",7]")));
}

TEST(RomiValidate, TypedCommands) {
  EXPECT_EQ(validate_request_payload(view("L[1]")), Error::no_error);
  EXPECT_EQ(validate_request_payload(view("M[16,\"Shutdown\"]")), Error::no_error);
  EXPECT_EQ(validate_request_payload(view("")), Error::client_empty_request);
  EXPECT_EQ(validate_request_payload(view("a:b")), Error::reserved_character);
  EXPECT_EQ(validate_request_payload(view("L[1")), Error::unexpected_char);
  EXPECT_EQ(validate_request_payload(view("m[" + std::string(60, '1') + "]")), Error::value_out_of_range);
  std::string long_payload = "m[";
  for (int i = 0; i < 12; ++i) long_payload += (i ? ",-9999" : "-9999");
  long_payload += "]";
  EXPECT_EQ(validate_request_payload(view(long_payload)), Error::client_request_too_long);
}

// Where an error was found: the offending character, a number's or a string's start, or the end.
TEST(RomiValidate, ErrorsSayWhereTheyWereFound) {
  const struct {
    const char* payload;
    Error error;
    size_t offset;
  } cases[] = {
      {"~", Error::invalid_opcode, 0},
      {"ab", Error::unexpected_char, 1},
      {"e[0,,1]", Error::unexpected_char, 4},
      {"e[0,1", Error::unexpected_char, 5},
      {"e[0]x", Error::unexpected_char, 4},
      {"e[]x", Error::unexpected_char, 3},
      {"e[-]", Error::unexpected_char, 3},
      {"e[1,40000]", Error::value_out_of_range, 4},
      {"e[1,-32769]", Error::value_out_of_range, 4},
      {"e[1,2,3,4,5,6,7,8,9,10,11,12,13]", Error::too_many_arguments, 29},
      {"e[1,\"aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\"]", Error::string_too_long, 4},
      {"e[\"a<b\"]", Error::invalid_string, 4},
      {"e[\"ab", Error::invalid_string, 5},
      {"e[\"a\",\"b\"]", Error::too_many_strings, 6},
      {"e[1:2]", Error::reserved_character, 3},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.payload);
    size_t offset = 1000;
    EXPECT_EQ(validate_request_payload(view(c.payload), offset), c.error);
    EXPECT_EQ(offset, c.offset);
  }
  // The device's parse finds the same errors without keeping an offset.
  Request request;
  EXPECT_EQ(parse_request(view("e[0,,1]"), request), Error::unexpected_char);
}

Request parsed(const std::string& payload, Error expected = Error::no_error) {
  Request request;
  EXPECT_EQ(parse_request(view(payload), request), expected) << payload;
  return request;
}

TEST(RomiRequestParser, ParsesOpcodeIntegersAndString) {
  const Request r = parsed("M[16,\"Shutdown\",-3]");
  EXPECT_EQ(r.opcode, 'M');
  ASSERT_EQ(r.argument_count, 2);
  EXPECT_EQ(r.arguments[0], 16);
  EXPECT_EQ(r.arguments[1], -3);
  EXPECT_TRUE(r.has_string);
  EXPECT_STREQ(r.string, "Shutdown");
  EXPECT_EQ(parsed("a").argument_count, 0);
  EXPECT_EQ(parsed("a[]").argument_count, 0);
  EXPECT_EQ(parsed("m[1,2,3,4,5,6,7,8,9,10,11,12]").arguments[11], 12);
  EXPECT_EQ(parsed("s[-32768,32767]").arguments[0], -32768);
  EXPECT_STREQ(parsed("t[\"\"]").string, "");
}

TEST(RomiRequestParser, AParsedRequestViewsItsStringInThePayload) {
  // What a device keeps: the string's characters where they arrived, between the quotes.
  const std::string payload = "M[16,\"Shutdown\",-3]";
  ParsedRequest request;
  ASSERT_EQ(parse_request(view(payload), request), Error::no_error);
  EXPECT_TRUE(request.has_string);
  EXPECT_EQ(reinterpret_cast<const char*>(request.string_view.data()), payload.data() + 6);
  EXPECT_EQ(request.string_view.size(), 8u);
  ASSERT_EQ(request.argument_count, 2);
  EXPECT_EQ(request.arguments[1], -3);
  // The next parse forgets it; an empty string is a string.
  ASSERT_EQ(parse_request(view("a[1]"), request), Error::no_error);
  EXPECT_FALSE(request.has_string);
  EXPECT_TRUE(request.string_view.empty());
  ASSERT_EQ(parse_request(view("t[\"\"]"), request), Error::no_error);
  EXPECT_TRUE(request.has_string);
  EXPECT_TRUE(request.string_view.empty());
}

TEST(RomiRequestParser, AReusedRequestKeepsEveryArgumentPastTheParsedOnesZero) {
  // The device parses into one Request per frame; only the arguments the last parse set are cleared.
  Request request;
  ASSERT_EQ(parse_request(view("m[1,2,3,4,5,6,7,8,9,10,11,12]"), request), Error::no_error);
  ASSERT_EQ(parse_request(view("m[7]"), request), Error::no_error);
  EXPECT_EQ(request.argument_count, 1);
  EXPECT_EQ(request.arguments[0], 7);
  for (int i = 1; i < kMaxArguments; ++i) EXPECT_EQ(request.arguments[i], 0) << i;
  // A failed parse counts what it stored, so the next one clears those too.
  ASSERT_EQ(parse_request(view("m[5,6,7,99999]"), request), Error::value_out_of_range);
  ASSERT_EQ(parse_request(view("a"), request), Error::no_error);
  for (int i = 0; i < kMaxArguments; ++i) EXPECT_EQ(request.arguments[i], 0) << i;
}

TEST(RomiRequestParser, EveryMessageParserErrorCode) {
  parsed("", Error::invalid_opcode);
  parsed("#", Error::invalid_opcode);
  parsed("a(1)", Error::unexpected_char);
  parsed("a[1", Error::unexpected_char);
  parsed("a[1,]", Error::unexpected_char);
  parsed("a[1]x", Error::unexpected_char);
  parsed("a[x]", Error::unexpected_char);
  parsed("a[-]", Error::unexpected_char);
  parsed("a[1 ,2]", Error::unexpected_char);  // no spaces between tokens
  parsed("m[1,2,3,4,5,6,7,8,9,10,11,12,13]", Error::too_many_arguments);
  parsed("a[32768]", Error::value_out_of_range);
  parsed("a[-32769]", Error::value_out_of_range);
  parsed("a[99999999999999999999]", Error::value_out_of_range);
  parsed("t[\"" + std::string(33, 'a') + "\"]", Error::string_too_long);
  parsed("t[\"a\tb\"]", Error::invalid_string);
  parsed("t[\"unterminated]", Error::invalid_string);
  parsed("t[\"a\",\"b\"]", Error::too_many_strings);
}

TEST(RomiRequestParser, ThirtyTwoCharacterStringIsAccepted) {
  EXPECT_EQ(std::string(parsed("t[\"" + std::string(32, 'z') + "\"]").string), std::string(32, 'z'));
}

TEST(RomiErrors, EveryCodeHasAMessage) {
  for (int code = -33; code <= 0; ++code) {
    if (code == -29) continue;  // left unassigned between the reference's and Tether's codes
    EXPECT_STRNE(describe(static_cast<int16_t>(code)), "unknown error") << code;
  }
  EXPECT_STREQ(describe(int16_t{-29}), "unknown error");
  EXPECT_STREQ(describe(int16_t{101}), "application error");
  EXPECT_TRUE(is_envelope_error(-1));
  EXPECT_TRUE(is_envelope_error(-6));
  EXPECT_FALSE(is_envelope_error(-7));
  EXPECT_FALSE(is_envelope_error(0));
}

}  // namespace
}  // namespace tether::romi
