// The schema loader: methods in wire order, the hash both ends compare, and the errors a user sees.
#include "tether/rpc/schema.hpp"

#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <unistd.h>

namespace {

using tether::rpc::Schema;
using tether::rpc::SchemaError;
using tether::rpc::SchemaOptions;

const std::filesystem::path kSchemas = TETHER_RPC_TEST_SCHEMAS;

std::string load_error(const std::filesystem::path& file, const SchemaOptions& options = {}) {
  try {
    (void)Schema::load(file, options);
  } catch (const SchemaError& e) {
    return e.what();
  }
  return "(loaded)";
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A directory of its own, removed at the end.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "tether-schema-XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

TEST(RpcSchema, MethodsInDeclarationOrderWithTheirTypes) {
  const Schema schema = Schema::load(kSchemas / "arm.proto");
  EXPECT_EQ(schema.service().full_name(), "arm.Arm");
  ASSERT_EQ(schema.methods().size(), 2u);
  const auto& move = schema.methods()[0];
  EXPECT_EQ(move.name, "MoveJoint");
  EXPECT_EQ(move.index, 0);
  EXPECT_EQ(move.input->full_name(), "arm.JointRequest");
  EXPECT_EQ(move.output->full_name(), "arm.JointReply");
  EXPECT_FALSE(move.streaming);
  const auto& watch = schema.methods()[1];
  EXPECT_EQ(watch.name, "Watch");
  EXPECT_EQ(watch.index, 1);
  EXPECT_EQ(watch.output->full_name(), "arm.State");
  EXPECT_TRUE(watch.streaming);
  EXPECT_EQ(schema.find("Watch"), &watch);
  EXPECT_EQ(schema.find("watch"), nullptr);  // names are exact
  EXPECT_EQ(schema.file(), kSchemas / "arm.proto");
  EXPECT_NE(schema.pool().FindMessageTypeByName("arm.State"), nullptr);
}

TEST(RpcSchema, HashIsStableAndFormatted) {
  const std::uint64_t hash = Schema::load(kSchemas / "arm.proto").hash();
  EXPECT_EQ(Schema::load(kSchemas / "arm.proto").hash(), hash);
  EXPECT_EQ(tether::rpc::format_hash(0x0123456789abcdefu), "0x0123456789abcdef");
  EXPECT_EQ(tether::rpc::format_hash(1), "0x0000000000000001");
}

TEST(RpcSchema, LayoutCommentsFileNameAndSizeBoundsDoNotChangeTheHash) {
  const std::uint64_t hash = Schema::load(kSchemas / "arm.proto").hash();
  EXPECT_EQ(Schema::load(kSchemas / "arm_reformatted.proto").hash(), hash);
  EXPECT_EQ(Schema::load(kSchemas / "arm_nanopb.proto").hash(), hash);
  // Read from another directory under another name: the same schema.
  TempDir dir;
  write_file(dir.path() / "renamed.proto", read_file(kSchemas / "arm.proto"));
  EXPECT_EQ(Schema::load(dir.path() / "renamed.proto").hash(), hash);
}

TEST(RpcSchema, WhatChangesTheWireChangesTheHash) {
  const std::uint64_t hash = Schema::load(kSchemas / "arm.proto").hash();
  EXPECT_NE(Schema::load(kSchemas / "arm_renumbered.proto").hash(), hash);
  EXPECT_NE(Schema::load(kSchemas / "arm_retyped.proto").hash(), hash);
  const Schema reordered = Schema::load(kSchemas / "arm_reordered.proto");
  EXPECT_NE(reordered.hash(), hash);  // the methods' indices moved
  EXPECT_EQ(reordered.methods()[0].name, "Watch");
}

TEST(RpcSchema, ImportsAreFoundAndHashed) {
  const Schema schema = Schema::load(kSchemas / "rover.proto");
  ASSERT_EQ(schema.methods().size(), 2u);
  EXPECT_EQ(schema.methods()[0].input->field(0)->message_type()->full_name(), "geometry.Point");
  EXPECT_EQ(schema.methods()[0].output->full_name(), "google.protobuf.Empty");  // a well-known type

  // The same files elsewhere: the same hash; an imported message changed: another hash.
  TempDir dir;
  write_file(dir.path() / "rover.proto", read_file(kSchemas / "rover.proto"));
  const std::string geometry = read_file(kSchemas / "common/geometry.proto");
  write_file(dir.path() / "common/geometry.proto", geometry);
  EXPECT_EQ(Schema::load(dir.path() / "rover.proto").hash(), schema.hash());
  std::string changed = geometry;
  changed.replace(changed.find("int32 y_mm = 2;"), 15, "int32 y_mm = 2; int32 z_mm = 3;");
  write_file(dir.path() / "common/geometry.proto", changed);
  EXPECT_NE(Schema::load(dir.path() / "rover.proto").hash(), schema.hash());
}

TEST(RpcSchema, ImportPathsAreSearchedAfterTheSchemasDirectory) {
  TempDir dir;
  write_file(dir.path() / "app/rover.proto", read_file(kSchemas / "rover.proto"));
  EXPECT_EQ(load_error(dir.path() / "app/rover.proto"),
            "common/geometry.proto: File not found.\n"
            "rover.proto:3:1: Import \"common/geometry.proto\" was not found or had errors.\n"
            "rover.proto:5:26: \"geometry.Point\" is not defined.\n"
            "rover.proto:8:52: \"geometry.Point\" is not defined.");
  SchemaOptions options;
  options.import_paths.push_back(kSchemas);
  EXPECT_EQ(Schema::load(dir.path() / "app/rover.proto", options).hash(),
            Schema::load(kSchemas / "rover.proto").hash());
}

TEST(RpcSchema, ProtocErrorsNameFileLineAndColumn) {
  // As protoc prints it (`protoc -I. --descriptor_set_out=/dev/null bad_type.proto`).
  EXPECT_EQ(load_error(kSchemas / "bad_type.proto"), "bad_type.proto:3:42: \"int33\" is not defined.");
}

TEST(RpcSchema, WhatTheCodecCannotCarryIsRefusedByName) {
  const std::string dir = kSchemas.string() + "/";
  EXPECT_EQ(load_error(kSchemas / "missing.proto"), dir + "missing.proto: no such file");
  EXPECT_EQ(load_error(kSchemas / "common"), dir + "common: not a file");
  EXPECT_EQ(load_error(kSchemas / "no_service.proto"),
            dir + "no_service.proto: no service: the methods are a service's rpcs");
  EXPECT_EQ(load_error(kSchemas / "empty_service.proto"), dir + "empty_service.proto: service Idle has no rpc");
  EXPECT_EQ(load_error(kSchemas / "two_services.proto"),
            dir + "two_services.proto: more than one service (Left, Right): name the one to serve");
  EXPECT_EQ(load_error(kSchemas / "client_stream.proto"),
            dir + "client_stream.proto: Upload.Send: client streaming is not carried (a method is a call or a "
                  "server stream)");
  EXPECT_EQ(load_error(kSchemas / "proto2.proto"), dir + "proto2.proto: a schema is proto3 (`syntax = \"proto3\";`)");
  SchemaOptions options;
  options.service = "Middle";
  EXPECT_EQ(load_error(kSchemas / "two_services.proto", options), dir + "two_services.proto: no service Middle");
}

TEST(RpcSchema, OneOfSeveralServicesIsChosenByName) {
  SchemaOptions options;
  options.service = "Right";
  const Schema schema = Schema::load(kSchemas / "two_services.proto", options);
  EXPECT_EQ(schema.service().name(), "Right");
  EXPECT_EQ(schema.methods().size(), 2u);
  options.service = "Left";
  EXPECT_NE(Schema::load(kSchemas / "two_services.proto", options).hash(), schema.hash());
}

}  // namespace

namespace {

TEST(RpcSchema, LoadAllGivesEachServiceItsSchemaAndAFileOfMessagesNone) {
  const std::vector<Schema> both = Schema::load_all(kSchemas / "two_services.proto");
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(both[0].service().full_name(), "pair.Left");
  EXPECT_EQ(both[1].service().full_name(), "pair.Right");
  SchemaOptions right;
  right.service = "Right";
  EXPECT_EQ(both[1].hash(), Schema::load(kSchemas / "two_services.proto", right).hash());
  EXPECT_NE(both[0].hash(), both[1].hash());
  EXPECT_TRUE(Schema::load_all(kSchemas / "common" / "geometry.proto").empty());
  EXPECT_THROW(Schema::load_all(kSchemas / "bad_type.proto"), SchemaError);
}

}  // namespace
