// A schema with nanopb's field options inline (arm_nanopb.proto: `import "nanopb.proto"`) built by
// tether_generate_rpc: protoc's classes of nanopb.proto join the program, so the options are extensions
// of the compiled-in descriptors, and the schema hash still leaves them out.
#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

#include <string>

#include "arm_nanopb.tether.hpp"
#include "nanopb.pb.h"

namespace {

using tether::rpc::Schema;

const std::string kNanopbSchemas = TETHER_RPC_TEST_SCHEMAS;

TEST(RpcTypedNanopb, NanopbOptionsChangeNeitherTheBuildNorTheHash) {
  const google::protobuf::FieldOptions& options = arm::State::descriptor()->FindFieldByName("angles_cdeg")->options();
  ASSERT_TRUE(options.HasExtension(nanopb));  // known to the program: an extension, not an unknown field
  EXPECT_EQ(options.GetExtension(nanopb).max_count(), 8);
  const Schema compiled(arm::ArmClient::descriptor());
  EXPECT_EQ(compiled.hash(), arm::ArmClient::kSchemaHash);  // the generator's, from the file without them
  EXPECT_EQ(compiled.hash(), Schema::load(kNanopbSchemas + "/arm_nanopb.proto").hash());
  EXPECT_EQ(compiled.hash(), Schema::load(kNanopbSchemas + "/arm.proto").hash());
}

}  // namespace
