// parse_answer and the typed values: what a payload reads as (code, message, values), that the typed
// values are the same JSON a nlohmann document of the body is, and the conversions.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "tether/romi/errors.hpp"
#include "tether/romi/response.hpp"

namespace tether::romi {
namespace {

using nlohmann::json;

RomiResponse parse(const std::string& payload) {
  return parse_answer(ByteView::from_chars(payload.data(), payload.size()), payload.empty() ? '_' : payload[0]);
}

TEST(RomiResponse, TheSpecsAnswerIsReadIntoTypedIntegers) {
  const RomiResponse response = parse("e[0,1,2]");
  EXPECT_TRUE(response.answered);
  EXPECT_EQ(response.code, 0);
  EXPECT_EQ(response.message, "");
  EXPECT_EQ(response.opcode, 'e');
  EXPECT_EQ(response.raw, "e[0,1,2]");
  ASSERT_EQ(response.values.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(response.values[i].kind(), Value::Kind::integer);
    EXPECT_EQ(response.values[i].integer(), static_cast<std::int64_t>(i));
  }
  EXPECT_EQ(response.values, json::parse("[0,1,2]"));
  EXPECT_EQ(response.values.dump(), "[0,1,2]");
}

TEST(RomiResponse, EveryJsonKindIsKeptWithItsType) {
  const RomiResponse response =
      parse(R"(x[0,-32768,"t\"\u00e9",1.5,true,null,18446744073709551615,[1,[2,{"k":"v"}]],{"a":{"b":[3]}}])");
  ASSERT_EQ(response.code, 0);
  const Values& v = response.values;
  ASSERT_EQ(v.size(), 9u);
  EXPECT_EQ(v[1].integer(), -32768);
  EXPECT_EQ(v[2].string(), "t\"\xc3\xa9");
  EXPECT_EQ(v[3].kind(), Value::Kind::number);
  EXPECT_DOUBLE_EQ(v[3].number(), 1.5);
  EXPECT_TRUE(v[4].is_boolean() && v[4].boolean());
  EXPECT_TRUE(v[5].is_null());
  EXPECT_EQ(v[6].kind(), Value::Kind::unsigned_integer);
  EXPECT_EQ(v[6].unsigned_integer(), 18446744073709551615u);
  EXPECT_TRUE(v[7].is_structured());
  EXPECT_EQ(v[7].structured(), json::parse(R"([1,[2,{"k":"v"}]])"));
  EXPECT_EQ(v[8].structured(), json::parse(R"({"a":{"b":[3]}})"));
}

// The typed values are the document nlohmann's DOM parser makes of the same text (it was the parse path).
TEST(RomiResponse, TypedValuesConvertToTheDocumentOfTheBody) {
  const std::vector<std::string> bodies = {
      "[0]", "[0,1,2]", "[101,\"I will try again tomorrow\"]", "[0,512,-3,\"text\",1.5]", "[0,1e3,-2.5E-3,0.0]",
      "[0,\"\\\\ \\/ \\b\\f\\n\\r\\t \\ud83d\\ude00\"]", "[0,[],{},[[]],{\"a\":{}}]",
      "[0,{\"k\":1,\"k\":2}]", " [ 0 , 1 ] ", "[0,9223372036854775807,-9223372036854775808,9223372036854775808]",
      "[0,true,false,null]"};
  for (const std::string& body : bodies) {
    const RomiResponse response = parse("r" + body);
    const json document = json::parse(body);
    EXPECT_EQ(response.code, document[0].get<int>()) << body;
    EXPECT_EQ(response.values.to_json(), document) << body;
    EXPECT_EQ(response.values.dump(), document.dump()) << body;
    const json converted = response.values;  // the implicit conversion
    EXPECT_EQ(converted, document) << body;
  }
}

TEST(RomiResponse, TheMessageIsTheSecondValueOrTheCodesText) {
  EXPECT_EQ(parse("f[101,\"I will try again tomorrow\"]").message, "I will try again tomorrow");
  EXPECT_EQ(parse("f[101,\"I will try again tomorrow\"]").code, 101);
  EXPECT_EQ(parse("a[-17]").message, describe(static_cast<std::int16_t>(-17)));
  EXPECT_EQ(parse("a[5,6]").message, describe(static_cast<std::int16_t>(5)));
}

// Host codes for answers without a readable code; values are then [code, message].
TEST(RomiResponse, UnreadableAnswersGetHostCodes) {
  struct Case {
    std::string payload;
    Error error;
  };
  const std::vector<Case> cases = {
      {"e", Error::client_empty_response},     {"e[0,", Error::client_invalid_json},
      {"e5x", Error::client_invalid_json},     {"e[0]]", Error::client_invalid_json},
      {"e[\"\\x\"]", Error::client_invalid_json}, {"e[01]", Error::client_invalid_json},
      {"e5", Error::client_bad_response},      {"e{\"a\":[1]}", Error::client_bad_response},
      {"e[]", Error::client_bad_response},     {"e[1.5]", Error::client_bad_response},
      {"e[40000]", Error::client_bad_response}, {"e[-32769,1]", Error::client_bad_response},
      {"e[\"0\"]", Error::client_bad_response}, {"e[[0]]", Error::client_bad_response},
      // Above int64: nlohmann reads it unsigned; taking it as int64 made it -1, a device error code.
      {"e[18446744073709551615]", Error::client_bad_response}};
  for (const Case& c : cases) {
    const RomiResponse response = parse(c.payload);
    const auto code = static_cast<std::int16_t>(c.error);
    EXPECT_TRUE(response.answered) << c.payload;
    EXPECT_EQ(response.code, code) << c.payload;
    EXPECT_EQ(response.message, describe(code)) << c.payload;
    EXPECT_EQ(response.values, json::array({code, describe(code)})) << c.payload;
    EXPECT_EQ(response.raw, c.payload);
  }
}

TEST(RomiValues, ConvertFromAnyDocument) {
  const Values array = json::parse(R"([0,"a",[1]])");
  EXPECT_TRUE(array.is_array());
  ASSERT_EQ(array.size(), 3u);
  EXPECT_EQ(array[1].string(), "a");
  EXPECT_EQ(array.to_json(), json::parse(R"([0,"a",[1]])"));

  const Values scalar = json(5);
  EXPECT_FALSE(scalar.is_array());
  EXPECT_EQ(scalar.to_json(), json(5));
  EXPECT_EQ(Values(json::object()).to_json(), json::object());

  const nlohmann::ordered_json ordered = {{"values", array}};
  EXPECT_EQ(ordered.dump(), R"({"values":[0,"a",[1]]})");
  EXPECT_THROW((void)array.at(3), std::out_of_range);
  EXPECT_EQ(array.at(0).get<int>(), 0);
  EXPECT_TRUE(array[0] == 0);
  EXPECT_TRUE(array[1] == "a");
  std::ostringstream text;
  text << array;
  EXPECT_EQ(text.str(), R"([0,"a",[1]])");
}

TEST(RomiValues, TwelveValuesAndMoreAreKept) {
  std::string body = "[0";
  for (int i = 1; i < 40; ++i) body += "," + std::to_string(i);
  body += "]";
  const RomiResponse response = parse("e" + body);
  ASSERT_EQ(response.values.size(), 40u);
  EXPECT_EQ(response.values[39].integer(), 39);
  EXPECT_EQ(response.values, json::parse(body));
}

}  // namespace
}  // namespace tether::romi
