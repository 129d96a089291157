// The rpc plugin's texts: typed requests (every scalar kind, enums by name or number, JSON for repeated
// and nested fields, the errors that name the culprit) and the monitor's decoder on frames of both
// directions (methods and fields by name with the schema, the envelope without).
#include <gtest/gtest.h>

#include <google/protobuf/dynamic_message.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rpc_text.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/schema.hpp"
#include "tether_rpc.pb.h"

namespace tether::cli {
namespace {

namespace pb = google::protobuf;

const std::string kPluginSchemas = TETHER_RPC_PLUGIN_TEST_SCHEMAS;
const std::string kSchemas = TETHER_RPC_TEST_SCHEMAS;

class TypedRequest : public ::testing::Test {
 protected:
  rpc::Schema schema_ = rpc::Schema::load(kPluginSchemas + "/kinds.proto");
  pb::DynamicMessageFactory factory_{&schema_.pool()};
  std::unique_ptr<pb::Message> request_{factory_.GetPrototype(schema_.find("Set")->input)->New()};

  std::optional<std::string> fill(const std::vector<std::string>& words) {
    request_->Clear();
    return fill_rpc_request(*request_, words);
  }
};

TEST_F(TypedRequest, EveryScalarKindAndEnumsByNameOrNumber) {
  EXPECT_EQ(fill({"small=-7", "big=18446744073709551615", "negative=-9000000000", "ratio=0.5", "precise=-1e-3",
                  "on=true", "label=hello", "raw=eHk=", "mode=MODE_HOLD"}),
            std::nullopt);
  EXPECT_EQ(rpc_message_json(*request_),
            R"({"small":-7,"big":"18446744073709551615","negative":"-9000000000","ratio":0.5,"precise":-0.001,)"
            R"("on":true,"label":"hello","raw":"eHk=","mode":"MODE_HOLD","values":[]})");
  EXPECT_EQ(fill({"mode=1", "on=0"}), std::nullopt);
  EXPECT_EQ(rpc_message_value(*request_)["mode"], "MODE_RUN");
  EXPECT_EQ(fill({"labelText=x"}).value_or(""), "Everything has no field \"labelText\" (fields: small, big, negative, "
                                                 "ratio, precise, on, label, raw, mode, values, at)");
}

// Bytes in base64 as the JSON form takes them and the output prints them: what is printed can be given back.
TEST_F(TypedRequest, BytesAreBase64AsTheJsonFormAndTheOutput) {
  for (const std::string given : {"AQID", "AQI=", "AQI", "_-8=", "/+8", ""}) {
    SCOPED_TRACE(given);
    ASSERT_EQ(fill({"raw=" + given}), std::nullopt);
    const std::string words = request_->GetReflection()->GetString(*request_, request_->GetDescriptor()->FindFieldByName("raw"));
    ASSERT_EQ(fill({R"({"raw": ")" + given + R"("})"}), std::nullopt) << "the JSON form takes it too";
    EXPECT_EQ(request_->GetReflection()->GetString(*request_, request_->GetDescriptor()->FindFieldByName("raw")), words);
  }
  ASSERT_EQ(fill({"raw=AQID"}), std::nullopt);
  EXPECT_EQ(rpc_message_value(*request_)["raw"], "AQID");
  ASSERT_EQ(fill({"raw=/+8="}), std::nullopt);
  EXPECT_EQ(request_->GetReflection()->GetString(*request_, request_->GetDescriptor()->FindFieldByName("raw")),
            std::string("\xff\xef"));
  for (const std::string bad : {"AQI$", "A", "AQIDA", "a b", "AQ=D"}) {
    EXPECT_EQ(fill({"raw=" + bad}),
              "raw=\"" + bad + "\": expected base64 (protobuf's JSON form of bytes: AQID is 01 02 03)");
  }
}

// Bounds from the .options file beside the schema, as nanopb's generator reads it: the field named, with
// its bound and the file; what no line bounds is not checked.
TEST(RpcBounds, NameTheFieldOverItsOptionsBound) {
  const rpc::Schema schema = rpc::Schema::load(kPluginSchemas + "/bounds.proto");
  const RpcBounds bounds(schema);
  pb::DynamicMessageFactory factory(&schema.pool());
  const std::unique_ptr<pb::Message> request(factory.GetPrototype(schema.find("Configure")->input)->New());
  const auto check = [&](const std::string& json) {
    request->Clear();
    EXPECT_EQ(fill_rpc_request(*request, std::vector<std::string>{json}), std::nullopt) << json;
    return bounds.check(*request);
  };
  EXPECT_EQ(check(R"({"label": "abcde", "blob": "AQID", "thresholds": [1], "note": "ab", "free": "any length at all",)"
                  R"( "channels": [{"id": 1, "gain": {"unit": "abcd"}}, {}]})"),
            std::nullopt);
  EXPECT_EQ(check(R"({"label": "abcdef"})"),
            "label: 6 bytes, over its .options bound (bounds.options: max_size:6, a string of at most 5 bytes)");
  EXPECT_EQ(check(R"({"blob": "AQIDBA=="})"), "blob: 4 bytes, over its .options bound (bounds.options: max_size:3)");
  EXPECT_EQ(check(R"({"thresholds": [1, 2]})"),
            "thresholds: 2 values, over its .options bound (bounds.options: max_count:1)");
  EXPECT_EQ(check(R"({"channels": [{}, {}, {}]})"),
            "channels: 3 values, over its .options bound (bounds.options: max_count:2)");
  EXPECT_EQ(check(R"({"channels": [{}, {"gain": {"unit": "kelvin"}}]})"),
            "channels[1].gain.unit: 6 bytes, over its .options bound (bounds.options: max_length:4)");
  EXPECT_EQ(check(R"({"note": "abc"})"),  // the later line wins
            "note: 3 bytes, over its .options bound (bounds.options: max_size:3, a string of at most 2 bytes)");

  // No .options beside the schema: nothing is known, nothing refused.
  const rpc::Schema kinds = rpc::Schema::load(kPluginSchemas + "/kinds.proto");
  pb::DynamicMessageFactory kinds_factory(&kinds.pool());
  const std::unique_ptr<pb::Message> everything(kinds_factory.GetPrototype(kinds.find("Set")->input)->New());
  ASSERT_EQ(fill_rpc_request(*everything,
                             std::vector<std::string>{R"({"label": "a long label, longer than any bound", "values": [1]})"}),
            std::nullopt);
  EXPECT_EQ(RpcBounds(kinds).check(*everything), std::nullopt);
}

// The device cannot say which field it could not decode; the host's text hints at the likely cause.
TEST(RpcDeviceErrorLine, ARequestThatDoesNotDecodeHintsAtTheBounds) {
  rpc::DeviceError answer{0xFF02, "request does not decode"};
  EXPECT_EQ(rpc_device_error_line("Configure", make_error_code(rpc::RpcError::refused), answer).text,
            "Configure: refused 65282: request does not decode (a field over its .options bound?)");
  EXPECT_EQ(rpc_device_error_line("Configure", make_error_code(rpc::RpcError::refused), answer).json["text"],
            "request does not decode");  // the device's own text, as it sent it
  answer = {0xFF01, "unknown method"};
  EXPECT_EQ(rpc_device_error_line("Configure", make_error_code(rpc::RpcError::refused), answer).text,
            "Configure: refused 65281: unknown method");
  answer = {0xFF02, "mine"};  // an application's code is the application's
  EXPECT_EQ(rpc_device_error_line("Configure", make_error_code(rpc::RpcError::device_error), answer).text,
            "Configure: device error 65282: mine");
}

TEST_F(TypedRequest, JsonNamesAndTheWholeRequestAsJson) {
  EXPECT_EQ(fill({R"({"values": [1, 2, 3], "at": {"x": 4, "y": -5}, "mode": "MODE_RUN"})"}), std::nullopt);
  EXPECT_EQ(rpc_message_value(*request_)["values"], nlohmann::ordered_json::parse("[1,2,3]"));
  EXPECT_EQ(rpc_message_value(*request_)["at"]["y"], -5);
  EXPECT_NE(fill({R"({"values": "x"})"}).value_or("").find("the request as JSON (Everything): "), std::string::npos);
}

TEST_F(TypedRequest, BadValuesNameTheFieldAndWhatWasExpected) {
  EXPECT_EQ(fill({"small=2147483648"}), R"(small="2147483648": expected an integer in -2147483648..2147483647)");
  EXPECT_EQ(fill({"small=1x"}), R"(small="1x": expected an integer in -2147483648..2147483647)");
  EXPECT_EQ(fill({"on=yes"}), R"(on="yes": expected true or false)");
  EXPECT_EQ(fill({"ratio=1e39"}), R"(ratio="1e39": expected a number in float's range)");
  EXPECT_EQ(fill({"mode=MODE_FLY"}),
            R"(mode="MODE_FLY": expected a value of Mode: MODE_IDLE (0), MODE_RUN (1), MODE_HOLD (5))");
  EXPECT_EQ(fill({"mode=3"}), R"(mode="3": expected a value of Mode: MODE_IDLE (0), MODE_RUN (1), MODE_HOLD (5))");
  EXPECT_EQ(fill({"values=1"}), R"(values is repeated: give the whole request as JSON ('{"values": [...]}'))");
  EXPECT_EQ(fill({"at=1"}), R"(at is a message: give the whole request as JSON ('{"at": {...}}'))");
  EXPECT_EQ(fill({"small=1", "small=2"}), "small is given twice");
  EXPECT_EQ(fill({"=1"}), R"(expected FIELD=VALUE, got "=1")");
  EXPECT_EQ(fill({"label=\x1b[31m"}), std::nullopt);  // a string is the user's; a message about it is printable
  EXPECT_EQ(fill({"nope=\x1b"}).value_or(""), std::string("Everything has no field \"nope\" (fields: small, big, ") +
                                                   "negative, ratio, precise, on, label, raw, mode, values, at)");
}

// Frames as the client and the device write them.
std::string framed(const pb::Message& message) {
  const std::string payload = message.SerializeAsString();
  std::vector<std::uint8_t> frame(proxy::max_frame_size(payload.size()));
  const auto written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16,
                                           true, MutableByteView(frame.data(), frame.size()));
  return std::string(reinterpret_cast<const char*>(frame.data()), written.value());
}

std::vector<MonitorRecord> decode(MonitorDecoder& decoder, const std::string& bytes) {
  std::vector<MonitorRecord> records;
  for (const char c : bytes) decoder.feed(static_cast<std::uint8_t>(c), 0, records);
  return records;
}

TEST(RpcMonitorDecoder, BothDirectionsByMethodAndFieldNames) {
  auto schema = std::make_shared<const rpc::Schema>(rpc::Schema::load(kSchemas + "/arm.proto"));
  DecoderRole host_role;
  host_role.direction = Direction::host_to_device;
  const auto host = make_rpc_monitor_decoder(schema, host_role);
  const auto device = make_rpc_monitor_decoder(schema, DecoderRole());

  rpc::wire::HostMessage call;
  call.set_id(77);
  call.mutable_call()->set_method(0);
  call.mutable_call()->set_request(std::string("\x08\x02\x10\x64", 4));  // joint 2, angle_cdeg 100
  auto records = decode(*host, framed(call));
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(record_text(records[0]), R"(message  call MoveJoint {"joint":2,"angleCdeg":100} (id 77))");
  EXPECT_EQ(records[0].json["method"], "MoveJoint");

  rpc::wire::DeviceMessage reply;
  reply.mutable_reply()->set_call(77);
  reply.mutable_reply()->set_reply(std::string("\x08\x63", 2));  // reached_cdeg 99
  rpc::wire::DeviceMessage stream;
  stream.mutable_stream()->set_stream(78);
  stream.mutable_stream()->set_seq(4);
  stream.mutable_stream()->set_message(std::string("\x0a\x02\x01\x7f\x10\x05", 6));  // [1, 127], millis 5
  records = decode(*device, framed(reply) + framed(stream));
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(record_text(records[0]), R"(message  reply 77 MoveJoint {"reachedCdeg":99})");
  EXPECT_EQ(record_text(records[1]), R"(message  stream 78 #4 Watch {"anglesCdeg":[1,127],"millis":5})");
  EXPECT_EQ(records[1].json["fields"]["millis"], 5);
}

TEST(RpcMonitorDecoder, WithoutASchemaTheEnvelopeOnly) {
  const auto device = make_rpc_monitor_decoder(nullptr, DecoderRole());
  rpc::wire::DeviceMessage reply;
  reply.mutable_reply()->set_call(5);
  reply.mutable_reply()->set_reply(std::string("\x08\x63", 2));
  rpc::wire::DeviceMessage error;
  error.mutable_error()->set_call(6);
  error.mutable_error()->set_code(42);
  error.mutable_error()->set_text("locked");
  const auto records = decode(*device, framed(reply) + framed(error) + std::string("\x00\x05\x01\x02\x03\x00", 6));
  ASSERT_EQ(records.size(), 3u);
  EXPECT_EQ(record_text(records[0]), "message  reply 5 bytes [08 63]");
  EXPECT_EQ(record_text(records[1]), "message  device-error 6: 42 \"locked\"");
  EXPECT_EQ(records[2].kind, "error");  // a CRC that does not match
}

}  // namespace
}  // namespace tether::cli
