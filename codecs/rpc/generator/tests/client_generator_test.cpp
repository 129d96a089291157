// The typed C++ clients the generator writes (client_code): protoc's class names, one class per service in
// its package's namespace, the members of each kind of method, names it refuses. The clients' behaviour is
// tested where they are built (codecs/rpc: rpc.RpcTypedClient.*).
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <fstream>
#include <unistd.h>

#include "tether/rpc/generator.hpp"

namespace {

using tether::rpc::Schema;

const std::string kClientSchemas = TETHER_RPC_TEST_SCHEMAS;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A schema file of its own, removed at the end.
class SchemaFile {
 public:
  explicit SchemaFile(const std::string& text) {
    std::string pattern = (std::filesystem::temp_directory_path() / "tether-client-gen-XXXXXX").string();
    directory_ = mkdtemp(pattern.data());
    std::ofstream(directory_ / "robot.proto") << text;
  }
  ~SchemaFile() { std::filesystem::remove_all(directory_); }
  std::filesystem::path path() const { return directory_ / "robot.proto"; }
  const std::filesystem::path& directory() const { return directory_; }

 private:
  std::filesystem::path directory_;
};

std::string refusal(const std::string& proto) {
  const SchemaFile file(proto);
  try {
    (void)tether::rpc::client_code(Schema::load_all(file.path()), "robot");
  } catch (const tether::rpc::SchemaError& e) {
    return e.what();
  }
  return "(generated)";
}

TEST(RpcClientGenerator, ClassNamesAreProtocsNestedAndNamespaced) {
  google::protobuf::DescriptorPool pool;
  google::protobuf::FileDescriptorProto file;
  file.set_name("nested.proto");
  file.set_syntax("proto3");
  file.set_package("arm.v1");
  auto* outer = file.add_message_type();
  outer->set_name("Description");
  outer->add_nested_type()->set_name("Range");
  google::protobuf::FileDescriptorProto bare;
  bare.set_name("bare.proto");
  bare.set_syntax("proto3");
  bare.add_message_type()->set_name("Ping");
  ASSERT_NE(pool.BuildFile(file), nullptr);
  ASSERT_NE(pool.BuildFile(bare), nullptr);
  EXPECT_EQ(tether::rpc::cpp_class_name(*pool.FindMessageTypeByName("arm.v1.Description.Range")),
            "::arm::v1::Description_Range");
  EXPECT_EQ(tether::rpc::cpp_class_name(*pool.FindMessageTypeByName("arm.v1.Description")), "::arm::v1::Description");
  EXPECT_EQ(tether::rpc::cpp_class_name(*pool.FindMessageTypeByName("Ping")), "::Ping");
}

TEST(RpcClientGenerator, EachMethodIsAMemberOfItsKindOnProtocsClasses) {
  const auto code = tether::rpc::client_code(Schema::load_all(kClientSchemas + "/arm.proto"), "arm");
  const Schema arm = Schema::load(kClientSchemas + "/arm.proto");
  EXPECT_TRUE(has(code.header, "#include \"arm.pb.h\"\n#include \"tether/rpc/client.hpp\""));
  EXPECT_TRUE(has(code.header, "namespace arm {\n"));
  EXPECT_TRUE(has(code.header, "class ArmClient {"));
  EXPECT_TRUE(has(code.header, "static constexpr std::uint64_t kSchemaHash = " + tether::rpc::format_hash(arm.hash()) + "ull;"));
  EXPECT_TRUE(has(code.header, "  ::arm::JointReply MoveJoint(const ::arm::JointRequest& request) {\n"
                               "    return client_.call_as<::arm::JointReply>(\"MoveJoint\", request);"));
  EXPECT_TRUE(has(code.header, "::arm::JointReply MoveJoint(const ::arm::JointRequest& request, ::tether::rpc::error_code& error)"));
  EXPECT_TRUE(has(code.header, "auto async_MoveJoint(const ::arm::JointRequest& request, Token&& token) {"));
  EXPECT_TRUE(has(code.header, "::tether::rpc::Stream Watch(const ::arm::StateRequest& request, std::chrono::milliseconds period,\n"
                               "      std::function<void(const ::tether::rpc::error_code& error, const ::arm::State& message)> handler)"));
  EXPECT_FALSE(has(code.header, "async_Watch"));  // a stream is opened, not awaited
  EXPECT_TRUE(has(code.header, "::tether::rpc::Client& dynamic()"));
  EXPECT_TRUE(has(code.source, "#include \"arm.tether.hpp\""));
  EXPECT_TRUE(has(code.source, "::arm::JointRequest::descriptor()->file()->FindServiceByName(\"Arm\")"));
  EXPECT_TRUE(has(code.source, "ArmClient::ArmClient("));
}

TEST(RpcClientGenerator, OneClassPerServiceAndNoneForAFileOfMessages) {
  const auto pair = tether::rpc::client_code(Schema::load_all(kClientSchemas + "/two_services.proto"), "two_services");
  EXPECT_TRUE(has(pair.header, "class LeftClient {"));
  EXPECT_TRUE(has(pair.header, "class RightClient {"));
  EXPECT_TRUE(has(pair.header, "::pair::Empty Stop(const ::pair::Empty& request)"));
  const auto geometry = tether::rpc::client_code(Schema::load_all(kClientSchemas + "/common/geometry.proto"), "geometry");
  EXPECT_TRUE(has(geometry.header, "#include \"geometry.pb.h\""));
  EXPECT_FALSE(has(geometry.header, "class "));
  EXPECT_FALSE(has(geometry.source, "Client::"));
}

TEST(RpcClientGenerator, ImportedTypesKeepTheirOwnNamespaces) {
  const auto rover = tether::rpc::client_code(Schema::load_all(kClientSchemas + "/rover.proto"), "rover");
  EXPECT_TRUE(has(rover.header, "::google::protobuf::Empty Follow(const ::rover::Route& request)"));
  EXPECT_TRUE(has(rover.header, "const ::geometry::Point& message)> handler"));
}

TEST(RpcClientGenerator, AMethodNamedLikeAClientMemberIsRefused) {
  const std::string head = "syntax = \"proto3\";\npackage robot;\nmessage M {}\n";
  EXPECT_EQ(refusal(head + "service Robot { rpc close(M) returns (M); }\n"),
            "robot.proto: Robot.close: the name is one of RobotClient's own members: rename the method");
  EXPECT_EQ(refusal(head + "service Robot { rpc Go(M) returns (M); rpc async_Go(M) returns (M); }\n"),
            "robot.proto: Robot.Go: async_Go is both its asynchronous form and a method");
  EXPECT_EQ(refusal(head + "service Robot { rpc Go(M) returns (M); }\n"), "(generated)");
}

TEST(RpcClientGenerator, AMethodNamedLikeAKeywordOrThePrivateMemberIsRefused) {
  const std::string head = "syntax = \"proto3\";\npackage robot;\nmessage M {}\n";
  for (const std::string keyword : {"delete", "register", "co_await", "requires", "char8_t", "xor_eq"}) {
    EXPECT_EQ(refusal(head + "service Robot { rpc Go(M) returns (M); rpc " + keyword + "(M) returns (M); }\n"),
              "robot.proto: Robot." + keyword + ": " + keyword +
                  " is a C++ keyword, which cannot name a member of RobotClient: rename the method");
  }
  EXPECT_EQ(refusal(head + "service Robot { rpc client_(M) returns (M); }\n"),
            "robot.proto: Robot.client_: the name is one of RobotClient's own members: rename the method");
  EXPECT_EQ(refusal(head + "service Robot { rpc Delete(M) returns (M); rpc final(M) returns (M); }\n"), "(generated)");
}

TEST(RpcClientGenerator, ATypeNamedLikeTheClientClassIsRefused) {
  EXPECT_EQ(refusal("syntax = \"proto3\";\npackage cc;\nmessage SensorClient { int32 x = 1; }\n"
                    "service Sensor { rpc Get(SensorClient) returns (SensorClient); }\n"),
            "robot.proto: message cc.SensorClient has the name of service Sensor's client class (cc::SensorClient) "
            "in the same namespace: rename the message");
  EXPECT_EQ(refusal("syntax = \"proto3\";\nmessage M {}\nenum Kind { SensorClient = 0; }\n"
                    "service Sensor { rpc Get(M) returns (M); }\n"),
            "robot.proto: enum value SensorClient has the name of service Sensor's client class (SensorClient) in "
            "the same namespace: rename the enum value");
  // Nested, it is protoc's Outer_SensorClient.
  EXPECT_EQ(refusal("syntax = \"proto3\";\npackage cc;\nmessage M { message SensorClient {} }\n"
                    "service Sensor { rpc Get(M) returns (M); }\n"),
            "(generated)");
}

TEST(RpcClientGenerator, WritesTheTwoFilesNamedAfterTheSchema) {
  const SchemaFile file("syntax = \"proto3\";\npackage robot;\nmessage M {}\nservice Robot { rpc Go(M) returns (M); }\n");
  const auto written = tether::rpc::write_client_code(file.path(), {}, file.directory() / "out");
  ASSERT_EQ(written.size(), 2u);
  EXPECT_EQ(written[0], file.directory() / "out" / "robot.tether.hpp");
  EXPECT_EQ(written[1], file.directory() / "out" / "robot.tether.cpp");
  EXPECT_TRUE(std::filesystem::is_regular_file(written[0]));
  EXPECT_TRUE(std::filesystem::is_regular_file(written[1]));
}

}  // namespace
