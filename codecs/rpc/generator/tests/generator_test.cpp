// The service code the generator writes: names, handler signatures, the table's order, bad names.
#include "tether/rpc/generator.hpp"

#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

namespace {

using tether::rpc::Schema;

const std::string kSchemas = TETHER_RPC_TEST_SCHEMAS;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(RpcGenerator, NamesFollowNanopbAndTheService) {
  const Schema arm = Schema::load(kSchemas + "/arm.proto");
  EXPECT_EQ(tether::rpc::default_library_name(arm), "ArmRpc");
  EXPECT_EQ(tether::rpc::handler_name(arm, arm.methods()[1]), "Arm_Watch");
  EXPECT_EQ(tether::rpc::nanopb_name(*arm.methods()[0].input), "arm_JointRequest");
  const Schema rover = Schema::load(kSchemas + "/rover.proto");
  EXPECT_EQ(tether::rpc::nanopb_name(*rover.methods()[1].output), "geometry_Point");
  EXPECT_EQ(tether::rpc::nanopb_name(*rover.methods()[0].output), "google_protobuf_Empty");
}

TEST(RpcGenerator, TheHeaderDeclaresOneTypedHandlerPerMethodAndTheSchemaHash) {
  const Schema arm = Schema::load(kSchemas + "/arm.proto");
  const auto code = tether::rpc::service_code(arm, "ArmRpc", "arm.pb.h");
  EXPECT_TRUE(contains(code.header, "#include \"arm.pb.h\""));
  EXPECT_TRUE(contains(code.header,
                       "tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply);"));
  EXPECT_TRUE(contains(code.header, "tether::rpc::Status Arm_Watch(const arm_StateRequest& request, arm_State& next);"));
  EXPECT_TRUE(contains(code.header, "static constexpr uint64_t kSchemaHash = " + tether::rpc::format_hash(arm.hash()) + "ull;"));
  EXPECT_TRUE(contains(code.header, "struct ArmRpcService {"));
  EXPECT_TRUE(contains(code.header, "#ifndef arm_State_size\n#error \"arm.State has no size bound"));
  EXPECT_TRUE(contains(code.header, "static constexpr uint8_t kStreams = 1;"));
  // The table in the schema's order (the wire's method index), with each method's kind.
  const auto move = code.source.find("{&tether_rpc_decode_arm_JointRequest, &tether_rpc_encode_arm_JointReply, &call_MoveJoint, false},");
  const auto watch = code.source.find("{&tether_rpc_decode_arm_StateRequest, &tether_rpc_encode_arm_State, &call_Watch, true},");
  ASSERT_NE(move, std::string::npos);
  ASSERT_NE(watch, std::string::npos);
  EXPECT_LT(move, watch);
  EXPECT_TRUE(contains(code.source, "return Arm_MoveJoint(*static_cast<const arm_JointRequest*>(request), "
                                    "*static_cast<arm_JointReply*>(reply));"));
}

TEST(RpcGenerator, ALibraryNameMustBeAnIdentifier) {
  const Schema arm = Schema::load(kSchemas + "/arm.proto");
  EXPECT_THROW(tether::rpc::service_code(arm, "Arm-Rpc", "arm.pb.h"), tether::rpc::SchemaError);
  EXPECT_THROW(tether::rpc::service_code(arm, "9Arm", "arm.pb.h"), tether::rpc::SchemaError);
  EXPECT_THROW(tether::rpc::service_code(arm, "", "arm.pb.h"), tether::rpc::SchemaError);
}

}  // namespace
