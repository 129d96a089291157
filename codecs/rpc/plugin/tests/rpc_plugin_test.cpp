// The rpc plugin: an `rpc` device's options in a configuration (the schema read at parse time, relative to
// the configuration's folder; the client's timing), their errors, options built in code, and open_rover
// against the arm device on a pty (arm_on_pty.hpp): ready on the same schema, refused on another.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "arm_on_pty.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/rpc/plugin.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::rpc {
namespace {

namespace fs = std::filesystem;
using devices::ConfigError;

const fs::path kSchemas = fs::path(TETHER_RPC_TEST_SCHEMAS).lexically_normal();

std::string one_device(const std::string& options, const std::string& transport = R"({"serial": {"path": "/dev/null"}})") {
  return R"({"devices": [{"name": "arm", "codec": "rpc", "transport": )" + transport +
         (options.empty() ? std::string() : R"(, "options": )" + options) + "}]}";
}

devices::ParseOptions in_schemas() {
  devices::ParseOptions where;
  where.base_dir = kSchemas;
  return where;
}

// The ConfigError's what() of parsing `text` (fails the test if it parses).
std::string parse_error(const std::string& text, const devices::ParseOptions& where = in_schemas()) {
  try {
    (void)devices::parse_config(text, where);
  } catch (const ConfigError& error) {
    return error.what();
  }
  ADD_FAILURE() << "parsed: " << text;
  return "";
}

TEST(RpcPlugin, SchemaRelativeToTheConfigurationsFolderAndTimingKeys) {
  const devices::RoverConfig config = devices::parse_config(
      one_device(R"({"schema": "arm.proto", "call_budget_ms": 500, "processing_margin_ms": 20, "max_sends": 3,
                     "queue_timeout_ms": 700, "ping_period_ms": 0, "hello_timeout_ms": 250,
                     "first_message_id": 7, "open_timeout_ms": 900, "bits_per_byte": 10})",
                 R"({"serial": {"path": "/dev/null", "baud": 57600}})"),
      in_schemas());
  ASSERT_EQ(config.devices.size(), 1u);
  EXPECT_EQ(config.devices[0].codec, kCodec);
  const auto& options = config.devices[0].options.get<DeviceOptions>();
  EXPECT_EQ(options.schema, kSchemas / "arm.proto");
  EXPECT_EQ(options.client.timing.call_budget, 500u);
  EXPECT_EQ(options.client.timing.processing_margin, 20u);
  EXPECT_EQ(options.client.timing.max_sends, 3u);
  EXPECT_EQ(options.client.timing.queue_timeout, 700u);
  EXPECT_EQ(options.client.timing.ping_period, 0u);
  EXPECT_EQ(options.client.timing.hello_timeout, 250u);
  EXPECT_EQ(options.client.timing.bits_per_byte, 10u);
  EXPECT_EQ(options.client.timing.baud, 57600u);  // the serial transport's
  EXPECT_EQ(options.client.first_message_id, 7u);
  EXPECT_EQ(options.open_timeout, std::chrono::milliseconds(900));
}

TEST(RpcPlugin, ConfigurationFileResolvesTheSchemaBesideIt) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("rpc-plugin-" + std::to_string(::getpid()));
  fs::create_directories(dir / "schemas");
  fs::copy_file(kSchemas / "arm.proto", dir / "schemas" / "arm.proto", fs::copy_options::overwrite_existing);
  std::ofstream(dir / "rover.json") << one_device(R"({"schema": "schemas/arm.proto"})");
  const devices::RoverConfig config = devices::load_config(dir / "rover.json");
  EXPECT_EQ(config.devices[0].options.get<DeviceOptions>().schema, dir / "schemas" / "arm.proto");
  fs::remove_all(dir);
}

// A virtual device's image may ship its schema beside it (IMAGE.proto): no "schema" needed then.
TEST(RpcPlugin, AVirtualBoardsSchemaBesideItsImage) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("rpc-plugin-image-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "arm-image.elf") << "not read while parsing";
  const std::string device = R"({"devices": [{"name": "arm", "codec": "rpc",
      "transport": {"virtual": {"firmware": "arm-image"}}}]})";
  devices::ParseOptions where;
  where.firmware_dir = dir;
  EXPECT_EQ(parse_error(device, where),
            R"(devices[0].options: missing key "schema" (an rpc device needs its schema file; a virtual board's )"
            R"(image may have it beside it, IMAGE.proto))");
  fs::copy_file(kSchemas / "arm.proto", dir / "arm-image.proto");
  const devices::RoverConfig config = devices::parse_config(device, where);
  EXPECT_EQ(config.devices[0].options.get<DeviceOptions>().schema, dir / "arm-image.proto");
  fs::remove_all(dir);
}

TEST(RpcPlugin, AbsoluteSchemaAsGiven) {
  devices::ParseOptions elsewhere;
  elsewhere.base_dir = "/nonexistent";
  const std::string absolute = (kSchemas / "arm.proto").string();
  const devices::RoverConfig config =
      devices::parse_config(one_device(R"({"schema": ")" + absolute + R"("})"), elsewhere);
  EXPECT_EQ(config.devices[0].options.get<DeviceOptions>().schema, fs::path(absolute));
}

TEST(RpcPlugin, WithoutABaseFolderTheSchemaIsTheWorkingDirectorys) {
  // parse_config without ParseOptions::base_dir: "arm.proto" is looked up where the program runs.
  EXPECT_EQ(parse_error(one_device(R"({"schema": "no-such-schema.proto"})"), devices::ParseOptions()),
            "devices[0].options.schema: no-such-schema.proto: no such file");
}

TEST(RpcPlugin, SchemaErrorsNameTheKeyAndProtocsPosition) {
  EXPECT_EQ(parse_error(one_device(R"({"schema": "bad_type.proto"})")),
            R"(devices[0].options.schema: bad_type.proto:3:42: "int33" is not defined.)");
  EXPECT_EQ(parse_error(one_device(R"({"schema": "no_service.proto"})")).rfind("devices[0].options.schema: ", 0), 0u);
  EXPECT_EQ(parse_error(one_device(R"({"schema": "two_services.proto", "service": "Nope"})"))
                .rfind("devices[0].options.schema: ", 0),
            0u);
}

TEST(RpcPlugin, OptionErrors) {
  const std::string missing = R"(devices[0].options: missing key "schema" (an rpc device needs its schema file; )"
                              R"(a virtual board's image may have it beside it, IMAGE.proto))";
  EXPECT_EQ(parse_error(one_device("")), missing);
  EXPECT_EQ(parse_error(one_device("{}")), missing);
  EXPECT_EQ(parse_error(one_device(R"({"schema": ""})")), R"(devices[0].options.schema: expected a non-empty string, got string "")");
  EXPECT_EQ(parse_error(one_device(R"({"schema": "arm.proto", "call_budget": 5})")),
            R"(devices[0].options: unknown key "call_budget" (did you mean "call_budget_ms"?))");
  EXPECT_EQ(parse_error(one_device(R"({"schema": "arm.proto", "call_budget_ms": 0})")),
            "devices[0].options.call_budget_ms: expected an unsigned integer in 1..2147483647, got 0");
  EXPECT_EQ(parse_error(one_device(R"({"schema": "arm.proto", "import_paths": "common"})")),
            R"(devices[0].options.import_paths: expected an array of folders, got string "common")");
}

TEST(RpcPlugin, OptionsBuiltInCodeAreChecked) {
  devices::RoverConfig config;
  devices::DeviceConfig device;
  device.name = "arm";
  device.codec = kCodec;
  device.transport = devices::SerialTransport{"/dev/null", {}};
  device.options = DeviceOptions{};  // no schema
  config.devices.push_back(device);
  try {
    devices::validate(config);
    ADD_FAILURE() << "validated";
  } catch (const ConfigError& error) {
    EXPECT_STREQ(error.what(), "devices[0].options.schema: must name the schema file");
  }
}

devices::RoverConfig arm_on(const std::string& port, const std::string& extra = "") {
  return devices::parse_config(
      one_device(R"({"schema": "arm.proto", "open_timeout_ms": 20000)" + extra + "}",
                 R"({"serial": {"path": ")" + port + R"(", "boot_wait_ms": 0}})"),
      in_schemas());
}

TEST(RpcPlugin, OpensARoverWhoseDeviceServesTheSchema) {
  const std::uint64_t hash = Schema::load(kSchemas / "arm.proto").hash();
  testing::ArmOnPty device(hash);
  transports::IoThread io;
  devices::Rover rover = devices::open_rover(arm_on(device.path()), io.executor());
  const auto arm = rover.client<Client>("arm");
  ASSERT_NE(arm, nullptr);
  EXPECT_TRUE(arm->session().established);
  EXPECT_EQ(arm->call_json("MoveJoint", R"({"joint": 2, "angleCdeg": -4500})"), R"({"reachedCdeg":-4501})");
  EXPECT_EQ(device.with_device([](testing::ArmDevice& arm_device) { return arm_device.moves(); }), 1);
  rover.close();
}

TEST(RpcPlugin, ADeviceOfAnotherSchemaFailsTheOpenNamingBothHashesAndTheFile) {
  const std::uint64_t hash = Schema::load(kSchemas / "arm.proto").hash();
  testing::ArmOnPty device(hash ^ 0x1234);
  transports::IoThread io;
  try {
    (void)devices::open_rover(arm_on(device.path()), io.executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    const std::string text = error.what();
    EXPECT_EQ(error.path(), "devices[0].options.schema");
    EXPECT_EQ(error.code(), RpcError::schema_mismatch);
    EXPECT_NE(text.find(format_hash(hash)), std::string::npos) << text;
    EXPECT_NE(text.find(format_hash(hash ^ 0x1234)), std::string::npos) << text;
    EXPECT_NE(text.find("arm.proto"), std::string::npos) << text;
  }
}

TEST(RpcPlugin, NoDeviceAnsweringFailsTheOpenWithinItsTimeout) {
  transports::IoThread io;
  auto silent = transports::PtyStream::open(io.executor());
  try {
    (void)devices::open_rover(
        devices::parse_config(one_device(R"({"schema": "arm.proto", "open_timeout_ms": 300})",
                                         R"({"serial": {"path": ")" + silent->slave_path() + R"(", "boot_wait_ms": 0}})"),
                              in_schemas()),
        io.executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.code(), devices::DevicesError::device_not_ready);
    EXPECT_EQ(std::string(error.what()).rfind("devices[0]: no rpc session within 300 ms", 0), 0u) << error.what();
  }
  silent->close();
}

}  // namespace
}  // namespace tether::rpc
