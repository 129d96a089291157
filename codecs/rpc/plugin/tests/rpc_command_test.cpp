// The `tether` command on rpc devices: `call` (replies, JSON requests, device errors, refusals before
// anything opens, another schema, streams, --config/--device), `shell`, `monitor` and `stats`, against the
// arm device of the host tests served on a pty (arm_on_pty.hpp: the generated arm service on the real device
// runtime; the bare-metal rpc image is not used here).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "arm_on_pty.hpp"
#include "tether/rpc/schema.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether_process.hpp"

namespace tether::rpc {
namespace {

namespace fs = std::filesystem;
using cli::testing::Outcome;
using cli::testing::run_tether;
using cli::testing::Terminal;
using nlohmann::json;

const std::string kArm = (fs::path(TETHER_RPC_TEST_SCHEMAS) / "arm.proto").lexically_normal().string();

std::uint64_t arm_hash() {
  static const std::uint64_t hash = Schema::load(kArm).hash();
  return hash;
}

std::vector<std::string> call_on(const testing::ArmOnPty& device, std::vector<std::string> words) {
  std::vector<std::string> arguments = {"call", "--port", device.path(), "--codec", "rpc", "--schema", kArm};
  arguments.insert(arguments.end(), words.begin(), words.end());
  return arguments;
}

TEST(TetherRpcCall, PrintsTheReplyAsJson) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether(call_on(device, {"MoveJoint", "joint=2", "angle_cdeg=-4500"}));
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "{\"reachedCdeg\":-4501}\n");
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm) { return arm.last_angle(); }), -4500);
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm) { return arm.moves(); }), 1);
}

TEST(TetherRpcCall, JsonRequestAndJsonOutput) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether(call_on(device, {"--json", "MoveJoint", R"({"joint": 2, "angleCdeg": 7})"}));
  EXPECT_EQ(run.status, 0) << run.err;
  const json object = json::parse(run.out);
  EXPECT_EQ(object["method"], "MoveJoint");
  EXPECT_EQ(object["reply"], json::parse(R"({"reachedCdeg": 6})"));
  EXPECT_GE(object["attempts"].get<int>(), 1);
  EXPECT_TRUE(object.contains("message_id"));
}

TEST(TetherRpcCall, DeviceErrorExitsOneWithCodeAndText) {
  testing::ArmOnPty device(arm_hash());
  device.with_device([](testing::ArmDevice& arm) {
    arm.fail_moves(42, "joint 3 is locked");
    return 0;
  });
  const Outcome run = run_tether(call_on(device, {"MoveJoint", "joint=3"}));
  EXPECT_EQ(run.status, 1) << run.err;
  EXPECT_EQ(run.out, "");
  EXPECT_NE(run.err.find("tether call: MoveJoint: device error 42: joint 3 is locked"), std::string::npos) << run.err;

  const Outcome json_run = run_tether(call_on(device, {"--json", "MoveJoint", "joint=3"}));
  EXPECT_EQ(json_run.status, 1) << json_run.err;
  const json object = json::parse(json_run.out);
  EXPECT_EQ(object["error"], "device_error");
  EXPECT_EQ(object["code"], 42);
  EXPECT_EQ(object["text"], "joint 3 is locked");
}

// Refused before the device is opened: nothing reaches it.
TEST(TetherRpcCall, UnknownMethodFieldOrBadValueExitTwoNamingIt) {
  testing::ArmOnPty device(arm_hash());
  struct Case {
    std::vector<std::string> words;
    std::string message;
  };
  for (const Case& c : {Case{{"Jump"}, "no method \"Jump\" in " + kArm + " (methods: MoveJoint, Watch)"},
                        Case{{"MoveJoint", "jiont=2"}, "JointRequest has no field \"jiont\" (fields: joint, angle_cdeg)"},
                        Case{{"MoveJoint", "joint=-1"}, "joint=\"-1\": expected an integer in 0..4294967295"},
                        Case{{"MoveJoint", "joint"}, "expected FIELD=VALUE, got \"joint\""},
                        Case{{"MoveJoint", "{\"joint\": \"x\"}"}, "the request as JSON (JointRequest)"},
                        Case{{"Watch"}, "Watch is a stream: give --period MS"}}) {
    SCOPED_TRACE(::testing::PrintToString(c.words));
    const Outcome run = run_tether(call_on(device, c.words));
    EXPECT_EQ(run.status, 2);
    EXPECT_EQ(run.out, "");
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
  }
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm) { return arm.moves(); }), 0);
}

// A field over its bound in the .options file beside the schema is named before anything opens (the device
// would refuse the request without naming it).
TEST(TetherRpcCall, AFieldOverItsOptionsBoundIsNamedBeforeSending) {
  const fs::path bounds = fs::path(TETHER_RPC_TEST_SCHEMAS) / "../../../plugin/tests/schemas/bounds.proto";
  const Outcome run = run_tether({"call", "--port", "/dev/null", "--codec", "rpc", "--schema",
                                  bounds.lexically_normal().string(), "Configure", "label=abcdef"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "");
  EXPECT_NE(run.err.find("tether call: Configure: label: 6 bytes, over its .options bound (bounds.options: "
                         "max_size:6, a string of at most 5 bytes)"),
            std::string::npos)
      << run.err;
}

// A device that never answers: opening waits for its session within the call's budget (not the session's
// own 10 s), and says so.
TEST(TetherRpcCall, NoSessionWithinTheCallsBudget) {
  transports::IoThread io;
  const auto silent = transports::PtyStream::open(io.executor());  // nobody answers on its other side
  const auto start = std::chrono::steady_clock::now();
  const Outcome run = run_tether({"call", "--port", silent->slave_path(), "--codec", "rpc", "--schema", kArm,
                                  "--timeout", "300", "MoveJoint", "joint=1"});
  const auto took = std::chrono::steady_clock::now() - start;
  silent->close();
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "");
  EXPECT_NE(run.err.find("no rpc session within 300 ms (the call's budget): no DeviceHello answered our Hello"),
            std::string::npos)
      << run.err;
  EXPECT_EQ(run.err.find("waited too long before the first send"), std::string::npos) << run.err;
  EXPECT_LT(took, std::chrono::seconds(8));  // the session's own wait is 10 s
}

TEST(TetherRpcCall, SchemaTheDeviceRefusesExitsTwoNamingBothHashesAndTheFile) {
  testing::ArmOnPty device(arm_hash() ^ 0xF00D);
  const Outcome run = run_tether(call_on(device, {"MoveJoint", "joint=2"}));
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find(format_hash(arm_hash())), std::string::npos) << run.err;
  EXPECT_NE(run.err.find(format_hash(arm_hash() ^ 0xF00D)), std::string::npos) << run.err;
  EXPECT_NE(run.err.find(kArm), std::string::npos) << run.err;
}

TEST(TetherRpcCall, SchemaThatDoesNotReadOrIsMissing) {
  const fs::path bad = fs::path(TETHER_RPC_TEST_SCHEMAS) / "bad_type.proto";
  Outcome run = run_tether({"call", "--port", "/dev/null", "--codec", "rpc", "--schema", bad.string(), "MoveJoint"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("bad_type.proto:3:42: \"int33\" is not defined."), std::string::npos) << run.err;
  run = run_tether({"call", "--port", "/dev/null", "--schema", "/nonexistent/arm.proto", "MoveJoint"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--schema: /nonexistent/arm.proto: no such file"), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find("--schema.schema"), std::string::npos) << run.err;
  run = run_tether({"call", "--port", "/dev/null", "--codec", "rpc", "MoveJoint"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("no schema: give --schema FILE"), std::string::npos) << run.err;
}

TEST(TetherRpcCall, StreamPrintsOneObjectPerMessage) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether(call_on(device, {"Watch", "--period", "20", "--count", "3"}));
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> lines = run.lines();
  ASSERT_EQ(lines.size(), 3u) << run.out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const json message = json::parse(lines[i]);
    ASSERT_EQ(message["anglesCdeg"].size(), 2u) << lines[i];
    EXPECT_EQ(message["anglesCdeg"][0].get<int>(), -message["anglesCdeg"][1].get<int>()) << lines[i];
  }
}

// The command closes its stream on the device, and waits for the ack, before it exits: the device does
// not stream on until its failsafe.
TEST(TetherRpcCall, StreamIsClosedOnTheDeviceWhenTheCountIsReached) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether(call_on(device, {"Watch", "--period", "20", "--count", "2"}));
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.lines().size(), 2u) << run.out;
  EXPECT_EQ(run.err, "");
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm) { return arm.open_streams(); }), 0);
}

TEST(TetherRpcCall, DeviceOfAConfigurationWithTheSchemaBesideIt) {
  testing::ArmOnPty device(arm_hash());
  const fs::path dir = fs::path(::testing::TempDir()) / ("tether-rpc-call-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(kArm, dir / "arm.proto", fs::copy_options::overwrite_existing);
  std::ofstream(dir / "rover.json") << json{{"devices",
                                            {{{"name", "arm"},
                                              {"codec", "rpc"},
                                              {"transport", {{"serial", {{"path", device.path()}, {"boot_wait_ms", 0}}}}},
                                              {"options", {{"schema", "arm.proto"}}}}}}}
                                           .dump();
  const Outcome run =
      run_tether({"call", "--config", (dir / "rover.json").string(), "--device", "arm", "MoveJoint", "angle_cdeg=10"});
  fs::remove_all(dir);
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "{\"reachedCdeg\":9}\n");
}

// --schema names the codec when nothing else does: a port, or an image whose name says no codec (a
// sketch built with arduino-builder).
TEST(TetherRpcCall, SchemaWithoutCodecIsRpc) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether({"call", "--port", device.path(), "--schema", kArm, "MoveJoint", "joint=2"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "{\"reachedCdeg\":-1}\n");
}

TEST(TetherRpcVirtual, SchemaWithoutCodecIsRpcForAnImageNamedOtherwise) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  const fs::path dir = fs::path(::testing::TempDir()) / ("tether-rpc-sketch-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path image = cli::testing::firmware("rpc-example");
  fs::copy_file(image, dir / "ArmSketch.ino.elf", fs::copy_options::overwrite_existing);
  const Outcome run = run_tether({"call", "--virtual", (dir / "ArmSketch.ino.elf").string(), "--schema",
                                  fs::path(image).replace_extension(".proto").string(), "MoveJoint", "joint=1",
                                  "angle_cdeg=7"});
  fs::remove_all(dir);
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "{\"reachedCdeg\":7}\n");
}

TEST(TetherRpcCall, HelpOfTheCodec) {
  const Outcome run = run_tether({"call", "--codec", "rpc", "--help"});
  EXPECT_EQ(run.status, 0);
  EXPECT_EQ(run.out.rfind("usage: tether call --port PATH --codec rpc --schema FILE", 0), 0u) << run.out;
  // Without a device: the default codec's (Romi's), which points at the others'.
  EXPECT_NE(run_tether({"call", "--help"}).out.find("tether call --codec CODEC --help"), std::string::npos);
}

TEST(TetherRpcShell, CallsStreamsAndHelp) {
  testing::ArmOnPty device(arm_hash());
  Terminal terminal({"shell", "--port", device.path(), "--codec", "rpc", "--schema", kArm});
  ASSERT_TRUE(terminal.expect("rpc> ")) << terminal.screen();
  terminal.type("MoveJoint joint=2 angle_cdeg=100\n");
  EXPECT_TRUE(terminal.expect("MoveJoint -> {\"reachedCdeg\":99}")) << terminal.screen();
  terminal.type("MoveJoint {\"joint\": 1, \"angleCdeg\": 5}\n");
  EXPECT_TRUE(terminal.expect("MoveJoint -> {\"reachedCdeg\":4}")) << terminal.screen();
  terminal.type("MoveJoint joint=x\n");
  EXPECT_TRUE(terminal.expect("joint=\"x\": expected an integer")) << terminal.screen();
  terminal.type("Watch period=30\n");
  EXPECT_TRUE(terminal.expect("Watch streaming every 30 ms")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("Watch #2 {\"anglesCdeg\":[")) << terminal.screen();
  terminal.type("Watch stop\n");
  EXPECT_TRUE(terminal.expect("Watch stopped")) << terminal.screen();
  terminal.type(":help\n");
  EXPECT_TRUE(terminal.expect("MoveJoint joint=uint32 angle_cdeg=int32 -> JointReply")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("Watch stop")) << terminal.screen();
  terminal.type(":stats\n");
  EXPECT_TRUE(terminal.expect("replies")) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

TEST(TetherRpcStats, ReportsTheRpcCountersAndTheProbe) {
  testing::ArmOnPty device(arm_hash());
  const Outcome run = run_tether({"stats", "--port", device.path(), "--codec", "rpc", "--schema", kArm, "--duration",
                                  "0", "--probe", "MoveJoint joint=1 angle_cdeg=5", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["codec"], "rpc");
  EXPECT_EQ(report["rpc"]["replies"], 1);
  EXPECT_GE(report["rpc"]["hellos_sent"].get<int>(), 1);
  EXPECT_EQ(report["session"]["established"], true);
  EXPECT_EQ(report["session"]["schema_hash"], format_hash(arm_hash()));
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm) { return arm.last_angle(); }), 5);
}

// Passive: what the device says at boot (its ResetEvent, waiting in the pty) decoded from the envelope.
TEST(TetherRpcMonitor, DecodesTheEnvelope) {
  testing::ArmOnPty device(arm_hash(), 0x5E55);
  const Outcome run =
      run_tether({"monitor", "--port", device.path(), "--codec", "rpc", "--schema", kArm, "--count", "1", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json record = json::parse(run.lines().at(0));
  EXPECT_EQ(record["kind"], "message");
  EXPECT_EQ(record["message"], "reset-event");
  EXPECT_EQ(record["session"], 0x5E55);
}

// The example's bare-metal image (examples/rpc/arm.proto) on a virtual Uno: an rpc-* image speaks rpc, its
// boot's ResetEvent decoded; its schema ships beside it (rpc-example.proto), so a call needs no --schema;
// an image without one says what is missing.
TEST(TetherRpcVirtual, TheExampleImageSpeaksRpc) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  const Outcome monitor = run_tether({"monitor", "--virtual", "rpc-example", "--count", "1", "--json"});
  EXPECT_EQ(monitor.status, 0) << monitor.err;
  ASSERT_FALSE(monitor.lines().empty()) << monitor.err;
  EXPECT_EQ(json::parse(monitor.lines().at(0))["message"], "reset-event");

  const Outcome call = run_tether({"call", "--virtual", "rpc-example", "MoveJoint", "joint=1", "angle_cdeg=-4500"});
  EXPECT_EQ(call.status, 0) << call.err;
  EXPECT_EQ(call.out, "{\"reachedCdeg\":-4500}\n");
  const Outcome error = run_tether({"call", "--virtual", "rpc-example", "MoveJoint", "joint=9"});
  EXPECT_EQ(error.status, 1) << error.err;
  EXPECT_NE(error.err.find("MoveJoint: device error 1: no joint"), std::string::npos) << error.err;

  namespace fs = std::filesystem;
  const fs::path dir = fs::path(::testing::TempDir()) / ("tether-rpc-lone-image-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(cli::testing::firmware("rpc-example"), dir / "rpc-example.elf", fs::copy_options::overwrite_existing);
  const Outcome lone = run_tether({"call", "--virtual", (dir / "rpc-example.elf").string(), "MoveJoint", "joint=1"});
  EXPECT_EQ(lone.status, 2);
  EXPECT_NE(lone.err.find("no schema: give --schema FILE (the device's .proto; none beside the image)"), std::string::npos)
      << lone.err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace tether::rpc
