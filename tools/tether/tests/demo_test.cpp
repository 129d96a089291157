// `tether demo`: the main job, shortened, through the real binary: the table and the JSON report what the
// run did; bad arguments and bad configs are errors with a message.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>
#include <string>

#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

using nlohmann::json;

TEST(TetherDemo, ShortRunPrintsOneColumnPerDeviceWithMeasuredFigures) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const Outcome run = run_tether({"demo", "--iterations", "30", "--period", "10"});
  EXPECT_EQ(run.status, 0) << run.err;
  for (const char* expected : {"arm (romi)", "servos (proxy)", "legacy (proxy-compat)", "joints (rpc)", "ring (elcano)",
                               "ring-d (elcano)", "wire bytes / op", "latency p99 (ms)", "resets detected",
                               "recovered after (ms)", "servo pins (D9, D10)"}) {
    EXPECT_NE(run.out.find(expected), std::string::npos) << expected << "\n" << run.out;
  }
  EXPECT_NE(run.out.find("30 operations per device"), std::string::npos) << run.out;
}

TEST(TetherDemo, JsonReportAddsUpAndSeesTheProxyReset) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const Outcome run = run_tether({"demo", "--iterations", "30", "--period", "10", "--json", "--seed", "7"});
  ASSERT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["iterations"], 30);
  ASSERT_EQ(report["devices"].size(), 6u);
  for (const json& device : report["devices"]) {
    SCOPED_TRACE(device["device"].get<std::string>());
    EXPECT_EQ(device["operations"], 30);
    EXPECT_EQ(device["successes"].get<int>() + device["failures"].get<int>() + device["wrong"].get<int>(), 30);
    EXPECT_EQ(device["resets_injected"], 1);
    EXPECT_GT(device["bytes_to_device"].get<int>(), 0);
    EXPECT_EQ(device["pins_match"], true) << device["pins_detail"];
  }
  EXPECT_EQ(report["devices"][1]["resets_detected"], 1);   // proxy: the session id changed
  EXPECT_EQ(report["devices"][3]["resets_detected"], 1);   // rpc: likewise
  EXPECT_TRUE(report["devices"][0]["resets_detected"].is_null());  // romi cannot tell
}

TEST(TetherDemo, BadArgumentsAndConfigsAreErrorsWithAMessage) {
  Outcome run = run_tether({"demo", "--iterations", "0"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--iterations"), std::string::npos) << run.err;
  run = run_tether({"demo", "--ber", "lots"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--ber"), std::string::npos) << run.err;
  const std::string file = ::testing::TempDir() + "tether-demo-bad-config.json";
  std::ofstream(file) << R"({"devices": [{"name": "arm", "codec": "mavlink", "transport": {"tcp": {"host": "x", "port": 1}}}]})";
  run = run_tether({"demo", "--config", file});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("devices[0].codec"), std::string::npos) << run.err;
  // a directory read as an empty file ("invalid JSON ... unexpected end of input").
  run = run_tether({"demo", "--config", ::testing::TempDir()});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find(::testing::TempDir() + ": Is a directory"), std::string::npos) << run.err;
}

// Ctrl-C while the progress line is on the terminal: the line is erased before the demo dies, so the
// shell's prompt does not land behind it.
TEST(TetherDemo, CtrlCErasesTheProgressLine) {
  Terminal terminal({"demo", "--iterations", "100000"});
  ASSERT_TRUE(terminal.expect("tether demo: ")) << terminal.screen();
  terminal.type("\x03");
  ASSERT_TRUE(terminal.wait_exit().has_value()) << terminal.screen();
  const std::string screen = terminal.screen();
  const std::size_t erased = screen.rfind("\r\033[K");
  ASSERT_NE(erased, std::string::npos) << screen;
  EXPECT_GT(erased, screen.rfind("tether demo: ")) << screen;  // after the last progress text
}

}  // namespace
}  // namespace tether::cli::testing
