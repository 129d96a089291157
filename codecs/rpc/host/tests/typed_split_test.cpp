// A service whose file has no message of its own (its messages in an imported file), built by
// tether_generate_rpc into a static library: the typed client links protoc's code of the service's file
// although nothing else in the program refers to it, so the service is in the compiled-in pool.
#include <gtest/gtest.h>

#include "split_service.tether.hpp"

namespace {

TEST(RpcTypedSplit, AServiceInAFileWithoutMessagesIsLinkedIn) {
  const google::protobuf::ServiceDescriptor& service = split::SplitClient::descriptor();
  EXPECT_EQ(service.full_name(), "split.Split");
  ASSERT_EQ(service.method_count(), 1);
  EXPECT_EQ(service.method(0)->input_type()->full_name(), "split.Request");
  EXPECT_EQ(tether::rpc::Schema(service).hash(), split::SplitClient::kSchemaHash);
}

}  // namespace
