// `tether generate`: the Arduino library it writes for a schema (its files, nanopb's code of the schema and
// its imports, the kit's runtime with 64-bit fields) and its refusals (exit status 2 with the reason, nothing
// written): no schema, no --out, a schema that does not read, a bad name, a folder in the way, nanopb or the
// kit missing. Building the library with arduino-builder and running it: codecs/rpc/arduino/tests.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tether_process.hpp"

namespace tether::rpc {
namespace {

namespace fs = std::filesystem;
using cli::testing::Outcome;
using cli::testing::run_tether;

const fs::path kSchemas = fs::path(TETHER_RPC_TEST_SCHEMAS).lexically_normal();
const std::string kArmSchema = (kSchemas / "arm.proto").string();

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A fresh folder for one test's output.
fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("tether-generate-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void expect_refused(const Outcome& run, const std::string& reason) {
  EXPECT_EQ(run.status, 2) << run.err;
  EXPECT_TRUE(contains(run.err, reason)) << run.err;
  EXPECT_EQ(run.out, "");
}

TEST(TetherRpcGenerate, WritesTheArduinoLibraryOfTheSchema) {
  const fs::path out = scratch("writes");
  const Outcome run = run_tether({"generate", kArmSchema, "--out", out.string()});
  ASSERT_EQ(run.status, 0) << run.err;
  const fs::path library = out / "ArmRpc";
  EXPECT_EQ(run.out, library.string() + "\n");
  const std::string properties = read(library / "library.properties");
  EXPECT_TRUE(contains(properties, "name=ArmRpc\n")) << properties;
  EXPECT_TRUE(contains(properties, "includes=ArmRpc.h\n")) << properties;
  EXPECT_TRUE(contains(properties, "depends=TetherCore\n")) << properties;
  EXPECT_TRUE(contains(properties, "architectures=avr\n")) << properties;
  const std::string header = read(library / "src" / "ArmRpc.h");
  EXPECT_TRUE(contains(header, "class ArmRpc : public tether::arduino::RpcDevice<ArmRpcService> {")) << header;
  EXPECT_TRUE(contains(header, "#include \"ArmRpc_service.h\"")) << header;
  // The service code is the generator's (write_service_code), on nanopb's code of the schema with its
  // .options bounds.
  EXPECT_TRUE(contains(read(library / "src" / "ArmRpc_service.h"),
                       "tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply);"));
  EXPECT_TRUE(fs::exists(library / "src" / "ArmRpc_service.cpp"));
  EXPECT_TRUE(contains(read(library / "src" / "arm.pb.h"), "int32_t angles_cdeg[8]"));  // arm.options: max_count:8
  EXPECT_TRUE(fs::exists(library / "src" / "arm.pb.c"));
  // The kit: the glue, the envelope's code and the nanopb runtime with 64-bit fields (the hello's hash).
  EXPECT_TRUE(fs::exists(library / "src" / "TetherRpcArduino.h"));
  EXPECT_TRUE(fs::exists(library / "src" / "tether_rpc.pb.c"));
  EXPECT_TRUE(fs::exists(library / "src" / "tether" / "rpc" / "device" / "rpc_device.hpp"));
  const std::string pb = read(library / "src" / "pb.h");
  EXPECT_TRUE(contains(pb, "#define PB_BUFFER_ONLY 1")) << pb.substr(0, 300);
  EXPECT_FALSE(contains(pb.substr(0, 300), "PB_WITHOUT_64BIT")) << pb.substr(0, 300);
  EXPECT_TRUE(contains(read(library / "GENERATED.txt"), "tether generate"));
  // Nothing left beside it.
  std::vector<std::string> entries;
  for (const auto& entry : fs::directory_iterator(out)) entries.push_back(entry.path().filename().string());
  EXPECT_EQ(entries, std::vector<std::string>{"ArmRpc"});
}

TEST(TetherRpcGenerate, NameAndImportsGoWhereNanopbsIncludesExpectThem) {
  const fs::path out = scratch("imports");
  const Outcome run = run_tether({"generate", (kSchemas / "rover.proto").string(), "--out", out.string(), "--name",
                                  "MyRover"});
  ASSERT_EQ(run.status, 0) << run.err;
  const fs::path src = out / "MyRover" / "src";
  EXPECT_TRUE(contains(read(src / "MyRover.h"), "class MyRover : public tether::arduino::RpcDevice<MyRoverService>"));
  EXPECT_TRUE(fs::exists(src / "MyRover_service.cpp"));
  EXPECT_TRUE(fs::exists(src / "rover.pb.c"));
  EXPECT_TRUE(fs::exists(src / "common" / "geometry.pb.c"));
  EXPECT_TRUE(fs::exists(src / "google" / "protobuf" / "empty.pb.c"));
}

// Bounds given as nanopb's field options in the schema itself (`import "nanopb.proto"`): nanopb.proto
// carries no code of its own.
TEST(TetherRpcGenerate, NanopbFieldOptionsInTheSchemaGiveTheBounds) {
  const fs::path out = scratch("field-options");
  const Outcome run = run_tether({"generate", (kSchemas / "arm_nanopb.proto").string(), "--out", out.string()});
  ASSERT_EQ(run.status, 0) << run.err;
  const fs::path src = out / "ArmRpc" / "src";
  EXPECT_TRUE(contains(read(src / "arm_nanopb.pb.h"), "int32_t angles_cdeg[8]"));
  EXPECT_FALSE(fs::exists(src / "nanopb.pb.h"));
}

TEST(TetherRpcGenerate, UsageErrorsExitTwoWithTheReason) {
  const fs::path out = scratch("usage");
  expect_refused(run_tether({"generate", "--out", out.string()}), "no schema");
  expect_refused(run_tether({"generate", kArmSchema}), "no --out");
  expect_refused(run_tether({"generate", kArmSchema, "--out"}), "--out needs a value");
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string(), "--bogus"}), "--bogus");
  expect_refused(run_tether({"generate", kArmSchema, kArmSchema, "--out", out.string()}), "unexpected argument");
  EXPECT_TRUE(fs::is_empty(out));
  const Outcome help = run_tether({"generate", "--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(contains(help.out, "usage: tether generate SCHEMA.proto --out DIR")) << help.out;
}

TEST(TetherRpcGenerate, ASchemaThatDoesNotReadIsRefusedWithProtocsMessage) {
  const fs::path out = scratch("schema");
  expect_refused(run_tether({"generate", (kSchemas / "missing.proto").string(), "--out", out.string()}),
                 "missing.proto: no such file");
  expect_refused(run_tether({"generate", (kSchemas / "bad_type.proto").string(), "--out", out.string()}),
                 "bad_type.proto:");
  expect_refused(run_tether({"generate", (kSchemas / "no_service.proto").string(), "--out", out.string()}),
                 "no_service.proto");
  EXPECT_TRUE(fs::is_empty(out));
}

TEST(TetherRpcGenerate, ANameThatIsNotAnIdentifierIsRefused) {
  const fs::path out = scratch("name");
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string(), "--name", "Arm-Rpc"}),
                 "library name \"Arm-Rpc\" is not a C++ identifier");
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string(), "--name", "9Arm"}), "not a C++ identifier");
  // A name whose header would replace one of the kit's.
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string(), "--name", "TetherRpcArduino"}),
                 "clashes with the kit's TetherRpcArduino.h");
  EXPECT_TRUE(fs::is_empty(out));
}

TEST(TetherRpcGenerate, AnExistingFolderIsReplacedOnlyWithForceAndOnlyWhenGenerated) {
  const fs::path out = scratch("existing");
  ASSERT_EQ(run_tether({"generate", kArmSchema, "--out", out.string()}).status, 0);
  std::ofstream(out / "ArmRpc" / "src" / "stale.cpp") << "// left over\n";
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string()}), "exists and is not empty: give --force");
  EXPECT_TRUE(fs::exists(out / "ArmRpc" / "src" / "stale.cpp"));
  // --force replaces the whole generated folder: nothing of the old one stays.
  const Outcome forced = run_tether({"generate", kArmSchema, "--out", out.string(), "--force"});
  EXPECT_EQ(forced.status, 0) << forced.err;
  EXPECT_FALSE(fs::exists(out / "ArmRpc" / "src" / "stale.cpp"));
  EXPECT_TRUE(fs::exists(out / "ArmRpc" / "src" / "ArmRpc.h"));
  // A folder of the user's own is never replaced.
  fs::create_directories(out / "Mine");
  std::ofstream(out / "Mine" / "notes.txt") << "mine\n";
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string(), "--name", "Mine", "--force"}),
                 "was not written by `tether generate`");
  EXPECT_EQ(read(out / "Mine" / "notes.txt"), "mine\n");
  // An empty folder is taken.
  fs::create_directories(out / "Empty");
  EXPECT_EQ(run_tether({"generate", kArmSchema, "--out", out.string(), "--name", "Empty"}).status, 0);
  EXPECT_TRUE(fs::exists(out / "Empty" / "src" / "Empty.h"));
}

TEST(TetherRpcGenerate, AMissingNanopbOrKitIsNamedAndNothingIsLeft) {
  const fs::path out = scratch("missing");
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string()},
                            {"TETHER_NANOPB_GENERATOR=" + (out / "no-nanopb_generator.py").string()}),
                 "could not be run (Debian: apt install nanopb");
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string()},
                            {"TETHER_RPC_ARDUINO_DIR=" + (out / "no-kit").string()}),
                 "the Arduino kit is missing");
  // nanopb refusing the schema's options: its exit status is named, the staging folder removed.
  expect_refused(run_tether({"generate", kArmSchema, "--out", out.string()}, {"TETHER_NANOPB_GENERATOR=/bin/false"}),
                 "nanopb's generator failed on");
  EXPECT_TRUE(fs::is_empty(out)) << fs::directory_iterator(out)->path();
}

}  // namespace
}  // namespace tether::rpc
