// `tether ports`: the serial ports of a fake sysfs/by-id tree (TETHER_SYSFS_ROOT, TETHER_DEV_ROOT), as a
// table and as JSON, and which device of a configuration each one is.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>
#include <string>
#include <vector>

#include "tether/transports/testing/fake_port_tree.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

using json = nlohmann::json;

struct Machine {
  transports::testing::FakePortTree tree;
  Machine() {
    tree.add_usb_tty("ttyACM0", "1-1", "2341", "0043", "75833353035351E0E1A1", "Arduino (www.arduino.cc)", "Arduino Uno");
    tree.add_usb_tty("ttyUSB0", "1-2", "0403", "6001", "A50285BI", "FTDI", "FT232R USB UART", 1);
    tree.add_platform_tty("ttyS0", "serial8250");
    tree.add_by_id("usb-Arduino__www.arduino.cc__0043_75833353035351E0E1A1-if00", "../../ttyACM0");
  }
  std::vector<std::string> environment() const {
    return {"TETHER_SYSFS_ROOT=" + tree.sysfs().string(), "TETHER_DEV_ROOT=" + tree.dev().string()};
  }
  std::string path(const std::string& name) const { return (tree.dev() / name).string(); }
  // A rover configuration file in the tree's folder.
  std::string config(const std::string& text) const {
    const std::string file = (tree.dev().parent_path() / "rover.json").string();
    std::ofstream(file) << text;
    return file;
  }
};

TEST(TetherPorts, ListsEveryPortAsJson) {
  Machine machine;
  const Outcome run = run_tether({"ports", "--json"}, machine.environment());
  ASSERT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  ASSERT_EQ(report["ports"].size(), 2u);
  EXPECT_EQ(report["ports"][0], json({{"path", machine.path("ttyACM0")},
                                      {"by_id", "usb-Arduino__www.arduino.cc__0043_75833353035351E0E1A1-if00"},
                                      {"vid", "2341"},
                                      {"pid", "0043"},
                                      {"serial", "75833353035351E0E1A1"},
                                      {"manufacturer", "Arduino (www.arduino.cc)"},
                                      {"product", "Arduino Uno"}}));
  EXPECT_EQ(report["ports"][1]["path"], machine.path("ttyUSB0"));
  EXPECT_EQ(report["ports"][1]["vid"], "0403");
  EXPECT_EQ(report["ports"][1]["by_id"], "");
  EXPECT_FALSE(report.contains("unmatched"));
}

TEST(TetherPorts, ListsEveryPortAsATable) {
  Machine machine;
  const Outcome run = run_tether({"ports"}, machine.environment());
  ASSERT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> lines = run.lines();
  ASSERT_EQ(lines.size(), 3u) << run.out;
  EXPECT_TRUE(matches(lines[0], "PORT~VID:PID~SERIAL~MANUFACTURER~PRODUCT~BY-ID")) << lines[0];
  EXPECT_TRUE(matches(lines[1], machine.path("ttyACM0") +
                                    "~2341:0043~75833353035351E0E1A1~Arduino (www.arduino.cc)~Arduino Uno~usb-Arduino_*"))
      << lines[1];
  EXPECT_TRUE(matches(lines[2], machine.path("ttyUSB0") + "~0403:6001~A50285BI~FTDI~FT232R USB UART~-")) << lines[2];
}

TEST(TetherPorts, ShowsWhichConfiguredDeviceEachPortIs) {
  Machine machine;
  const std::string config = machine.config(
      R"({"devices": [)"
      R"({"name": "arm", "codec": "romi", "transport": {"serial": {"port": {"usb": {"vid": "2341", "pid": "0043"}}}}},)"
      R"({"name": "servos", "codec": "proxy", "transport": {"serial": {"path": ")" + machine.path("ttyUSB0") + R"("}}},)"
      R"({"name": "nav", "codec": "romi", "transport": {"serial": {"port": {"by_id": "usb-gone-if00"}}}},)"
      R"({"name": "sim", "codec": "romi", "transport": {"tcp": {"host": "localhost", "port": 4001}}}]})");
  const Outcome run = run_tether({"ports", "--config", config, "--json"}, machine.environment());
  ASSERT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["ports"][0]["devices"], json({"arm"}));
  EXPECT_EQ(report["ports"][1]["devices"], json({"servos"}));
  EXPECT_EQ(report["unmatched"], json::parse(R"([{"device": "nav", "port": "by-id usb-gone-if00"}])"));

  const Outcome table = run_tether({"ports", "--config", config}, machine.environment());
  ASSERT_EQ(table.status, 0) << table.err;
  const std::vector<std::string> lines = table.lines();
  ASSERT_EQ(lines.size(), 4u) << table.out;
  EXPECT_TRUE(matches(lines[0], "PORT~*~BY-ID~DEVICE")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "*~arm")) << lines[1];
  EXPECT_TRUE(matches(lines[2], "*~-~servos")) << lines[2];
  EXPECT_EQ(lines[3], "not found: nav (by-id usb-gone-if00)");
}

TEST(TetherPorts, NoPorts) {
  transports::testing::FakePortTree tree;
  const Outcome run = run_tether({"ports"}, {"TETHER_SYSFS_ROOT=" + tree.sysfs().string(),
                                             "TETHER_DEV_ROOT=" + tree.dev().string()});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "no serial ports found\n");
  const Outcome json_run = run_tether({"ports", "--json"}, {"TETHER_SYSFS_ROOT=" + tree.sysfs().string(),
                                                            "TETHER_DEV_ROOT=" + tree.dev().string()});
  EXPECT_EQ(json::parse(json_run.out), json::parse(R"({"ports": []})"));
}

TEST(TetherPorts, BadArgumentsAndConfigurations) {
  Machine machine;
  Outcome run = run_tether({"ports", "--bogus"}, machine.environment());
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("unknown argument --bogus"), std::string::npos) << run.err;
  run = run_tether({"ports", "--config"}, machine.environment());
  EXPECT_EQ(run.status, 2);
  const std::string config = machine.config(
      R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"serial": {"port": {"usb": {"vid": "2G41"}}}}}]})");
  run = run_tether({"ports", "--config", config}, machine.environment());
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find(R"(devices[0].transport.serial.port.usb.vid: expected 4 hex digits ("2341"), got string "2G41")"),
            std::string::npos)
      << run.err;
}

}  // namespace
}  // namespace tether::cli::testing
