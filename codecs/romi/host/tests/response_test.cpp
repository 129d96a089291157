// parse_answer and the typed values: what a payload reads as (code, message, values), that the typed
// values are the same JSON a nlohmann document of the body is, and the conversions.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "tether/romi/errors.hpp"
#include "tether/testing/random_seed.hpp"
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
      "[0,true,false,null]", "[-0]", "[0,\"\"]", "[0,\"a]b\",\"c,d\"]", "[0,\"\xc3\xa9\"]", "[0,-1,-32768]",
      "[0,-9223372036854775808,1]", "[0,1.0]", "[0,2e2]", "[0,\"\\\"\"]", "[0,\"x\"]"};
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

// What an answer body means, read through a nlohmann document (the parse path before typed values, with
// codes above int64 rejected like every code outside int16).
struct Meaning {
  std::int16_t code = 0;
  json values;
};
Meaning through_a_document(const std::string& body) {
  const json document = json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (document.is_discarded()) return {static_cast<std::int16_t>(Error::client_invalid_json), json()};
  const bool integer = document.is_array() && !document.empty() && document[0].is_number_integer();
  const bool in_range =
      integer && (document[0].is_number_unsigned() ? document[0].get<std::uint64_t>() <= 32767u
                                                   : document[0].get<std::int64_t>() >= -32768 &&
                                                         document[0].get<std::int64_t>() <= 32767);
  if (!in_range) return {static_cast<std::int16_t>(Error::client_bad_response), json()};
  return {static_cast<std::int16_t>(document[0].get<std::int64_t>()), document};
}

// Random short bodies from JSON's and Romi's characters: the typed reading (its direct path and the SAX
// path) means exactly what the document means, for valid and invalid text alike.
TEST(RomiResponse, RandomBodiesMeanWhatTheirDocumentMeans) {
  std::mt19937_64 random = ::tether::testing::seeded_generator(17);
  const std::string alphabet = "[[[]]],,,,\"\"\"-0123456789.eE \\atrufnl{}:xu";
  for (int i = 0; i < 20000; ++i) {
    std::string body = i % 2 == 0 ? "[" : "";
    const auto length = static_cast<int>(random() % 12);
    for (int k = 0; k < length; ++k) body.push_back(alphabet[random() % alphabet.size()]);
    if (i % 3 == 0) body.push_back(']');
    const RomiResponse response = parse("e" + body);
    const Meaning meaning = through_a_document(body);
    if (body.empty()) continue;  // -23, tested above
    ASSERT_EQ(response.code, meaning.code) << "body " << body;
    if (meaning.code == static_cast<std::int16_t>(Error::client_invalid_json) ||
        meaning.code == static_cast<std::int16_t>(Error::client_bad_response)) {
      ASSERT_EQ(response.values, json::array({meaning.code, describe(meaning.code)})) << "body " << body;
    } else {
      ASSERT_EQ(response.values, meaning.values) << "body " << body;
    }
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
      {"e[0,]", Error::client_invalid_json},   {"e[-]", Error::client_invalid_json},
      {"e[0x1]", Error::client_invalid_json},  {"e[0\"x\"]", Error::client_invalid_json},
      {"e[0,\"a]", Error::client_invalid_json}, {"e[0,\"a\tb\"]", Error::client_invalid_json},
      {"e[0] x", Error::client_invalid_json},  {"e[+1]", Error::client_invalid_json},
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
