// JsonMapping (json_mapping.hpp) against protobuf's util::JsonStringToMessage and MessageToJsonString: the
// same JSON printed, the same messages and error texts parsed, for random messages of a plain type (the
// direct path) and of a rich one (protobuf's), and random JSON around them (RANDOM_SEED repeats a run).
#include <gtest/gtest.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>
#include <google/protobuf/reflection.h>
#include <google/protobuf/util/json_util.h>

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tether/rpc/json_mapping.hpp"
#include "tether/rpc/schema.hpp"
#include "tether/testing/random_seed.hpp"

namespace {

namespace pb = google::protobuf;
using namespace tether;

class RpcJsonMapping : public ::testing::Test {
 protected:
  RpcJsonMapping()
      : schema_(rpc::Schema::load(std::string(TETHER_RPC_TEST_SCHEMAS) + "/json_types.proto")),
        factory_(&schema_.pool()),
        json_(schema_.pool()),
        plain_(factory_.GetPrototype(schema_.pool().FindMessageTypeByName("jt.Plain"))),
        rich_(factory_.GetPrototype(schema_.pool().FindMessageTypeByName("jt.Rich"))) {}

  // A random message; `tame`: only what the direct path takes (texts without characters protobuf escapes,
  // enum values the enum names), so that both paths are well exercised.
  std::unique_ptr<pb::Message> random_message(const pb::Message& prototype, std::mt19937_64& rng, bool tame) {
    tame_ = tame;
    std::unique_ptr<pb::Message> message(prototype.New());
    fill(*message, rng, 0);
    return message;
  }

  static std::int64_t random_integer(std::mt19937_64& rng) {
    switch (rng() % 6) {
      case 0: return 0;
      case 1: return static_cast<std::int64_t>(rng() % 100);
      case 2: return -static_cast<std::int64_t>(rng() % 100);
      case 3: return static_cast<std::int32_t>(rng());
      default: return static_cast<std::int64_t>(rng());
    }
  }
  std::string random_text(std::mt19937_64& rng) const {
    static const std::vector<std::string> kTame = {"joint", "A b", "0", "/", "x_y", "{}[]:,"};
    if (tame_) {
      std::string out;
      const int pieces = static_cast<int>(rng() % 4);
      for (int i = 0; i < pieces; ++i) out += kTame[rng() % kTame.size()];
      return out;
    }
    static const std::vector<std::string> kPieces = {"joint", "A b", "0", "\"", "\\", "<", ">", "&", "'", "=", "\n",
                                                     "\x01", "\x7f", "\xc3\xa9", "\xe2\x80\xa8", "\xf0\x9f\x98\x80", "/"};
    std::string out;
    const int pieces = static_cast<int>(rng() % 4);
    for (int i = 0; i < pieces; ++i) out += rng() % 2 == 0 ? kPieces[0] : kPieces[rng() % kPieces.size()];
    return out;
  }

  void set_value(pb::Message& message, const pb::FieldDescriptor* field, std::mt19937_64& rng, int depth) {
    const pb::Reflection& r = *message.GetReflection();
    const bool repeated = field->is_repeated();
    const std::int64_t value = random_integer(rng);
    switch (field->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_INT32:
        repeated ? r.AddInt32(&message, field, static_cast<std::int32_t>(value)) : r.SetInt32(&message, field, static_cast<std::int32_t>(value));
        break;
      case pb::FieldDescriptor::CPPTYPE_UINT32:
        repeated ? r.AddUInt32(&message, field, static_cast<std::uint32_t>(value)) : r.SetUInt32(&message, field, static_cast<std::uint32_t>(value));
        break;
      case pb::FieldDescriptor::CPPTYPE_INT64:
        repeated ? r.AddInt64(&message, field, value) : r.SetInt64(&message, field, value);
        break;
      case pb::FieldDescriptor::CPPTYPE_UINT64:
        repeated ? r.AddUInt64(&message, field, static_cast<std::uint64_t>(value)) : r.SetUInt64(&message, field, static_cast<std::uint64_t>(value));
        break;
      case pb::FieldDescriptor::CPPTYPE_DOUBLE:
        r.SetDouble(&message, field, static_cast<double>(value) / 7.0);
        break;
      case pb::FieldDescriptor::CPPTYPE_FLOAT:
        r.SetFloat(&message, field, static_cast<float>(value) / 3.0f);
        break;
      case pb::FieldDescriptor::CPPTYPE_BOOL:
        repeated ? r.AddBool(&message, field, value % 2 != 0) : r.SetBool(&message, field, value % 2 != 0);
        break;
      case pb::FieldDescriptor::CPPTYPE_ENUM: {
        // 7: a number the enum does not name
        const int number = !tame_ && rng() % 5 == 0 ? 7 : static_cast<int>(rng() % 3);
        repeated ? r.AddEnumValue(&message, field, number) : r.SetEnumValue(&message, field, number);
        break;
      }
      case pb::FieldDescriptor::CPPTYPE_STRING: {
        const std::string text = random_text(rng);
        repeated ? r.AddString(&message, field, text) : r.SetString(&message, field, text);
        break;
      }
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        if (field->is_map()) {
          pb::Message* entry = r.AddMessage(&message, field);
          entry->GetReflection()->SetString(entry, entry->GetDescriptor()->field(0), random_text(rng));
          entry->GetReflection()->SetInt32(entry, entry->GetDescriptor()->field(1), static_cast<std::int32_t>(value));
        } else if (depth < 3) {
          fill(repeated ? *r.AddMessage(&message, field) : *r.MutableMessage(&message, field), rng, depth + 1);
        }
        break;
    }
  }

  void fill(pb::Message& message, std::mt19937_64& rng, int depth) {
    const pb::Descriptor* type = message.GetDescriptor();
    if (type->full_name() == "google.protobuf.Timestamp") {
      message.GetReflection()->SetInt64(&message, type->field(0), static_cast<std::int64_t>(rng() % 2000000000));
      return;
    }
    for (int i = 0; i < type->field_count(); ++i) {
      const pb::FieldDescriptor* field = type->field(i);
      if (rng() % 3 == 0) continue;
      const int count = field->is_repeated() ? static_cast<int>(rng() % 4) : 1;
      for (int n = 0; n < count; ++n) set_value(message, field, rng, depth);
    }
  }

  // Both ways of printing `message` agree, for every option set worth telling apart.
  void expect_same_printing(const pb::Message& message) {
    for (int variant = 0; variant < 6; ++variant) {
      pb::util::JsonPrintOptions options;
      options.always_print_primitive_fields = variant % 2 == 1;
      options.preserve_proto_field_names = variant == 2;
      options.add_whitespace = variant == 3;
      options.always_print_enums_as_ints = variant == 4;
      std::string expected;
      const pb::util::Status expected_status = pb::util::MessageToJsonString(message, &expected, options);
      std::string actual = "kept:";  // appended to, as protobuf's
      const pb::util::Status status = json_.to_json(message, actual, options);
      ASSERT_EQ(status.ToString(), expected_status.ToString()) << message.ShortDebugString();
      ASSERT_EQ(actual, "kept:" + expected) << "variant " << variant << ": " << message.ShortDebugString();
    }
  }

  // Both ways of parsing `json` into a `prototype` agree (status, text, message), into an empty message and
  // into one already filled.
  void expect_same_parsing(const pb::Message& prototype, const std::string& json, const pb::Message* filled = nullptr) {
    std::unique_ptr<pb::Message> expected(prototype.New());
    std::unique_ptr<pb::Message> actual(prototype.New());
    if (filled != nullptr) {
      expected->CopyFrom(*filled);
      actual->CopyFrom(*filled);
    }
    const pb::util::Status expected_status = pb::util::JsonStringToMessage(json, expected.get());
    const pb::util::Status status = json_.from_json(json, *actual);
    ASSERT_EQ(status.ToString(), expected_status.ToString()) << json;
    ASSERT_EQ(actual->SerializeAsString(), expected->SerializeAsString()) << json;
  }

  bool tame_ = false;
  rpc::Schema schema_;
  pb::DynamicMessageFactory factory_;
  rpc::JsonMapping json_;
  const pb::Message* plain_;
  const pb::Message* rich_;
};

TEST_F(RpcJsonMapping, PrintsAsProtobuf) {
  std::mt19937_64 rng = tether::testing::seeded_generator(11);
  for (int round = 0; round < 3000; ++round) {
    expect_same_printing(*random_message(round % 3 == 0 ? *rich_ : *plain_, rng, round % 3 == 1));
  }
  expect_same_printing(*plain_);  // every field unset
}

TEST_F(RpcJsonMapping, ParsesAsProtobuf) {
  std::mt19937_64 rng = tether::testing::seeded_generator(12);
  static const std::vector<std::string> kInserts = {"{", "}", "[", "]", ",", ":", "\"", "\\", "-", "0", "1", "e",
                                                    ".", "null", "true", " ", "\"i32\":", "\"late\":1,", "\"x\":"};
  for (int round = 0; round < 3000; ++round) {
    const pb::Message& prototype = round % 3 == 0 ? *rich_ : *plain_;
    const std::unique_ptr<pb::Message> message = random_message(prototype, rng, round % 3 == 1);
    pb::util::JsonPrintOptions options;
    options.always_print_primitive_fields = rng() % 2 == 0;
    options.preserve_proto_field_names = rng() % 3 == 0;
    options.add_whitespace = rng() % 4 == 0;
    options.always_print_enums_as_ints = rng() % 5 == 0;
    std::string json;
    ASSERT_TRUE(pb::util::MessageToJsonString(*message, &json, options).ok());
    ASSERT_NO_FATAL_FAILURE(expect_same_parsing(prototype, json));
    for (int mutation = 0; mutation < 3; ++mutation) {
      std::string mutated = json;
      const std::size_t at = rng() % (mutated.size() + 1);
      switch (rng() % 3) {
        case 0: mutated.insert(at, kInserts[rng() % kInserts.size()]); break;
        case 1: if (at < mutated.size()) mutated.erase(at, 1 + rng() % 3); break;
        default: if (at < mutated.size()) mutated[at] = static_cast<char>(' ' + rng() % 95); break;
      }
      ASSERT_NO_FATAL_FAILURE(expect_same_parsing(prototype, mutated));
    }
    // Into a message already filled: protobuf replaces it (or leaves it when it refuses).
    const std::unique_ptr<pb::Message> filled = random_message(prototype, rng, false);
    ASSERT_NO_FATAL_FAILURE(expect_same_parsing(prototype, json, filled.get()));
    ASSERT_NO_FATAL_FAILURE(expect_same_parsing(prototype, json + "x", filled.get()));
  }
}

TEST_F(RpcJsonMapping, ParsesTheEdgesAsProtobuf) {
  for (const std::string json : {
           "", " ", "{}", " { } ", "[]", "{} x", "{\"i32\": 2147483647}", "{\"i32\": 2147483648}",
           "{\"i32\": -2147483648}", "{\"i32\": -2147483649}", "{\"i32\": -0}", "{\"i32\": 01}", "{\"i32\": 1.0}",
           "{\"i32\": 1e2}", "{\"i32\": \"5\"}", "{\"i32\": null}", "{\"i32\": 1, \"i32\": 2}", "{\"i32\": +1}",
           "{\"snakeCaseName\": 3, \"snake_case_name\": 4}", "{\"snakeCaseName\": 3}", "{\"snake_case_name\": 3}",
           "{\"SnakeCaseName\": 3}", "{\"u32\": -1}", "{\"u32\": 4294967295}", "{\"u64\": 18446744073709551615}",
           "{\"i64\": -9223372036854775808}", "{\"i64\": \"12\"}", "{\"color\": \"COLOR_RED\"}", "{\"color\": 1}",
           "{\"color\": \"NOPE\"}", "{\"color\": \"color_red\"}", "{\"text\": \"a\\\"b\"}", "{\"text\": \"\xc3\xa9\"}",
           "{\"text\": \"\\u00e9\"}", "{\"text\": \"tab\there\"}", "{\"inner\": {}}", "{\"inner\": {\"a\": 1, \"child\": {}}}",
           "{\"inner\": null}", "{\"many\": []}", "{\"many\": [1,2,]}", "{\"many\": [1 2]}", "{\"many\": 1}",
           "{\"flag\": true}", "{\"flag\": True}", "{\"flag\": truex}", "{\"flag\": truefalse}", "{\"flag\": 1}", "{\"flags\": [true,false]}",
           "{\"inners\": [{\"a\": 1}, {}]}", "{\"i32\": 1,}", "{,}", "{\"i32\" 1}", "{\"i32\": 1", "{\"i32\":\t1\r\n}",
           "{\"i32\":\v1}", "{\"late\": 5, \"i32\": 1}", "{\"nope\": 1}", "{'i32': 1}", "{\"i32\": 1}\n"}) {
    ASSERT_NO_FATAL_FAILURE(expect_same_parsing(*plain_, json));
  }
  // Nesting deeper than the direct path takes.
  std::string deep = "{\"inner\":";
  for (int i = 0; i < 40; ++i) deep += "{\"child\":";
  deep += "{}";
  for (int i = 0; i < 41; ++i) deep += "}";
  deep += "}";
  ASSERT_NO_FATAL_FAILURE(expect_same_parsing(*plain_, deep));
}

}  // namespace
