// The service code the generator writes: names, handler signatures, the table's order, bad names; what it
// and the Arduino library refuse before anything is written (schemas that would not build on the AVR).
#include "tether/rpc/generator.hpp"

#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <utility>
#include <vector>

namespace {

using tether::rpc::Schema;

const std::string kSchemas = TETHER_RPC_TEST_SCHEMAS;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

namespace fs = std::filesystem;

// A folder of its own for schema files (and a library's output), removed at the end.
class Scratch {
 public:
  Scratch() {
    std::string pattern = (fs::temp_directory_path() / "tether-gen-XXXXXX").string();
    directory_ = mkdtemp(pattern.data());
  }
  ~Scratch() { fs::remove_all(directory_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  fs::path write(const std::string& file, const std::string& text) const {
    fs::create_directories((directory_ / file).parent_path());
    std::ofstream(directory_ / file) << text;
    return directory_ / file;
  }
  const fs::path& path() const { return directory_; }

 private:
  fs::path directory_;
};

// What service_code says of `proto` (as robot.proto) with the default library name, or "(generated)".
std::string service_refusal(const std::string& proto) {
  const Scratch scratch;
  const Schema schema = Schema::load(scratch.write("robot.proto", proto));
  try {
    (void)tether::rpc::service_code(schema, tether::rpc::default_library_name(schema), "robot.pb.h");
  } catch (const tether::rpc::SchemaError& e) {
    return e.what();
  }
  return "(generated)";
}

// What write_arduino_library says of `file` (with `text`, beside the `imports`), given a kit of TetherRpcArduino.h and the
// envelope's nanopb code; "(written)" if it got as far as running nanopb's generator (there is none). It
// must refuse before anything is written.
std::string library_refusal(const std::string& file, const std::string& text,
                            const std::vector<std::pair<std::string, std::string>>& imports = {}) {
  const Scratch scratch;
  const fs::path proto = scratch.write("schema/" + file, text);
  for (const auto& [name, contents] : imports) scratch.write("schema/" + name, contents);
  for (const char* kit_file : {"TetherRpcArduino.h", "tether_rpc.pb.h", "tether_rpc.pb.c"}) {
    scratch.write(std::string("kit/src/") + kit_file, "");
  }
  tether::rpc::ArduinoLibraryOptions options;
  options.kit = scratch.path() / "kit";
  options.nanopb_generator = scratch.path() / "no-nanopb";
  std::string said = "(written)";
  try {
    (void)tether::rpc::write_arduino_library(Schema::load(proto), scratch.path() / "out", options);
  } catch (const tether::rpc::SchemaError& e) {
    said = e.what();
  } catch (const tether::rpc::GenerateError& e) {
    said = e.what();
    if (contains(said, "nanopb's generator")) said = "(written)";
  }
  if (said != "(written)") {
    EXPECT_FALSE(fs::exists(scratch.path() / "out")) << said;
  }
  return said;
}

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

TEST(RpcGenerator, AFileWithServicesToChooseFromSaysHowToChoose) {
  const std::string two = kSchemas + "/two_services.proto";
  try {
    (void)tether::rpc::load_schema_to_serve(two, {}, "--service");
    ADD_FAILURE() << "loaded";
  } catch (const tether::rpc::SchemaError& e) {
    EXPECT_EQ(std::string(e.what()),
              two + ": more than one service (Left, Right): name the one to serve with --service NAME");
  }
  tether::rpc::SchemaOptions right;
  right.service = "Right";
  EXPECT_EQ(tether::rpc::load_schema_to_serve(two, right, "--service").service().name(), "Right");
  right.service = "Middle";
  try {
    (void)tether::rpc::load_schema_to_serve(two, right, "--service");
    ADD_FAILURE() << "loaded";
  } catch (const tether::rpc::SchemaError& e) {
    EXPECT_EQ(std::string(e.what()), two + ": no service Middle");
  }
}

TEST(RpcGenerator, AMessageThatContainsItselfIsRefusedNamingTheField) {
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage rc;\nmessage Node { int32 v = 1; Node child = 2; }\n"
                            "service Rec { rpc Walk(Node) returns (Node); }\n"),
            "robot.proto: rc.Node.child: a recursive field (rc.Node contains rc.Node through it): nanopb makes it a "
            "callback, which the device does not carry; nest messages of other types, one per level");
  // Through another message, and repeated.
  EXPECT_TRUE(contains(service_refusal("syntax = \"proto3\";\npackage rc;\nmessage A { B b = 1; }\n"
                                       "message B { repeated A a = 1; }\nmessage M {}\n"
                                       "service Rec { rpc Walk(M) returns (A); }\n"),
                       "robot.proto: rc.B.a: a recursive field (rc.A contains rc.A through it)"));
  // A message used twice is no loop.
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage rc;\nmessage P { int32 x = 1; }\n"
                            "message Two { P a = 1; P b = 2; }\nservice Rec { rpc Walk(Two) returns (Two); }\n"),
            "(generated)");
}

TEST(RpcGenerator, TwoNamesThatNanopbMergesAreRefusedNamingBoth) {
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage clash;\nmessage B_C { int32 x = 1; }\n"
                            "message B { message C { int32 y = 1; } C c = 1; }\n"
                            "service Clash { rpc Do(B) returns (B_C); }\n"),
            "robot.proto: message clash.B_C and message clash.B.C both become clash_B_C in nanopb's C code: rename "
            "one of them");
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage clash;\nenum Mode { Mode_ON = 0; }\n"
                            "message M { Mode mode = 1; }\nmessage Mode_Mode_ON {}\n"
                            "service Clash { rpc Do(M) returns (M); }\n"),
            "robot.proto: message clash.Mode_Mode_ON and enum value clash.Mode_ON both become clash_Mode_Mode_ON in "
            "nanopb's C code: rename one of them");
}

TEST(RpcGenerator, TheLibrarysNamesTakenByNanopbsAreRefused) {
  // Without a package nanopb's names are the messages' own: the class ThingRpc would be a typedef too.
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\nmessage ThingRpc { int32 x = 1; }\n"
                            "service Thing { rpc Get(ThingRpc) returns (ThingRpc); }\n"),
            "robot.proto: the library's class ThingRpc is also nanopb's name of message ThingRpc: rename the "
            "message, or give the library another name (--name)");
  EXPECT_TRUE(contains(service_refusal("syntax = \"proto3\";\nmessage M {}\nmessage ThingRpcService {}\n"
                                       "service Thing { rpc Get(M) returns (M); }\n"),
                       "the library's service struct ThingRpcService is also nanopb's name of message ThingRpcService"));
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\nmessage M {}\nmessage Thing_Get {}\n"
                            "service Thing { rpc Get(M) returns (M); }\n"),
            "robot.proto: the handler Thing_Get is also nanopb's name of message Thing_Get: rename the message, or "
            "the method Thing.Get");
  // One of nanopb's macros of a message (Thing_Go_x_tag, the field's tag).
  EXPECT_TRUE(contains(service_refusal("syntax = \"proto3\";\nmessage Thing_Go { int32 x = 1; }\n"
                                       "service Thing { rpc Go_x_tag(Thing_Go) returns (Thing_Go); }\n"),
                       "the handler Thing_Go_x_tag is also nanopb's name of message Thing_Go"));
  // In a package they are apart.
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage p;\nmessage ThingRpc { int32 x = 1; }\n"
                            "service Thing { rpc Get(ThingRpc) returns (ThingRpc); }\n"),
            "(generated)");
}

TEST(RpcGenerator, TheKitsPrefixIsRefused) {
  EXPECT_EQ(service_refusal("syntax = \"proto3\";\npackage tether.rpc.wire;\nmessage HostMessage {}\n"
                            "service Mine { rpc Do(HostMessage) returns (HostMessage); }\n"),
            "robot.proto: message tether.rpc.wire.HostMessage becomes tether_rpc_wire_HostMessage in nanopb's C "
            "code, and names starting tether_rpc_ are the kit's: use another package");
}

TEST(RpcGenerator, ASchemaFileNamedLikeAKitFileIsRefusedBeforeAnythingIsWritten) {
  const std::string mine = "syntax = \"proto3\";\npackage mine;\nmessage Req { int32 x = 1; }\n"
                           "service Mine { rpc Do(Req) returns (Req); }\n";
  EXPECT_EQ(library_refusal("tether_rpc.proto", mine),
            "tether_rpc.proto: nanopb's code of it would be tether_rpc.pb.h, which is the name of one of the kit's "
            "own files: rename tether_rpc.proto");
  EXPECT_TRUE(contains(library_refusal("Tether_RPC.proto", mine), "would be Tether_RPC.pb.h"));  // macOS, Windows
  EXPECT_EQ(library_refusal("mine.proto", "syntax = \"proto3\";\nimport \"tether_rpc.proto\";\n"
                                          "service Mine { rpc Do(mine.Req) returns (mine.Req); }\n",
                            {{"tether_rpc.proto", "syntax = \"proto3\";\npackage mine;\nmessage Req {}\n"}}),
            "tether_rpc.proto: nanopb's code of it would be tether_rpc.pb.h, which is the name of one of the kit's "
            "own files: rename tether_rpc.proto and the import lines that name it");
  EXPECT_EQ(library_refusal("mine.proto", mine), "(written)");
}

TEST(RpcGenerator, ADoubleIsRefusedForTheAvrNamingTheField) {
  EXPECT_EQ(library_refusal("sensor.proto", "syntax = \"proto3\";\npackage hub;\nmessage M {}\n"
                                            "message Reading { message Where { double altitude_m = 1; } Where at = 1; }\n"
                                            "service Hub { rpc Get(M) returns (M); }\n"),
            "sensor.proto: hub.Reading.Where.altitude_m is a double: use float (a double on the AVR is 32-bit, and "
            "nanopb's code of a double does not build there)");
  EXPECT_EQ(library_refusal("sensor.proto", "syntax = \"proto3\";\npackage hub;\nmessage M { float x = 1; }\n"
                                            "service Hub { rpc Get(M) returns (M); }\n"),
            "(written)");
}

}  // namespace
