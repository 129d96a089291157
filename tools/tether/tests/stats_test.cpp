// `tether stats`: the counters of a session with virtual boards, as a table and as JSON. Assertions are on
// what the session certainly did (the probe answered, the handshake), never on how much time allowed.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "fake_port.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

using nlohmann::json;

void expect_link_counters(const json& link) {
  for (const char* name : {"frames_ok", "crc_errors", "framing_errors", "oversize_frames", "resyncs",
                           "partial_timeouts", "stale", "duplicates", "retries", "timeouts", "resets", "failsafes"}) {
    EXPECT_TRUE(link.contains(name) && link[name].is_number_unsigned()) << name;
  }
}

TEST(TetherStats, RomiProbeCountsAsTraffic) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  // --duration 0: open, one probe, print. romi-test has no '?' handler: its -16 answer is still a frame.
  const Outcome run = run_tether({"stats", "--virtual", "romi-test", "--duration", "0", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["codec"], "romi");
  EXPECT_NE(report["device"].get<std::string>().find("romi-test.elf"), std::string::npos);
  expect_link_counters(report["link"]);
  EXPECT_EQ(report["link"]["frames_ok"], 1);
  EXPECT_EQ(report["link"]["crc_errors"], 0);
  EXPECT_EQ(report["calls"], json::parse(R"({"probe":"?","sent":1,"answered":1,"failed":0})"));
}

TEST(TetherStats, ProbeCommandThroughTheSimPtyAsATable) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  SimBoard board("romi-test");
  const Outcome run = run_tether({"stats", "--port", board.pty(), "--probe", "e", "--duration", "0"});
  EXPECT_EQ(run.status, 0) << run.err;
  auto has = [&](const std::string& pattern) { return matches(run.out, "*" + pattern + "*"); };
  EXPECT_TRUE(has("codec~romi\n")) << run.out;
  EXPECT_TRUE(has("\nlink\n  frames_ok~1\n  crc_errors~0\n")) << run.out;
  EXPECT_TRUE(has("\ncalls\n  probe~e\n  sent~1\n  answered~1\n  failed~0\n")) << run.out;
}

TEST(TetherStats, ProxySessionCounters) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const Outcome run = run_tether({"stats", "--virtual", "proxy", "--duration", "0", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["codec"], "proxy");
  expect_link_counters(report["link"]);
  // Opening waits for the handshake: our Reset went out and the device's ResetEvent came back.
  EXPECT_GE(report["link"]["frames_ok"].get<int>(), 1);
  EXPECT_GE(report["proxy"]["resets_sent"].get<int>(), 1);
  EXPECT_EQ(report["session"]["established"], true);
  EXPECT_TRUE(report["session"]["session_id"].is_number_unsigned());
}

TEST(TetherStats, ElcanoRingFromTheRoverConfiguration) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const Outcome run = run_tether({"stats", "--config", kRover, "--device", "ring", "--duration", "0", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["codec"], "elcano");
  expect_link_counters(report["link"]);
  for (const char* name :
       {"captured", "forwarded", "originated", "undeliverable", "queue_full_drops", "bytes_written"}) {
    EXPECT_TRUE(report["ring"].contains(name)) << name;
  }
}

TEST(TetherStats, PassiveRomiSendsNothing) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const Outcome run = run_tether({"stats", "--virtual", "romi-test", "--passive", "--duration", "0", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["calls"]["sent"], 0);
  EXPECT_EQ(report["link"]["frames_ok"], 0);
}

// Ctrl-C while the device opens ends the run with 0, as SIGINT does later.
TEST(TetherStats, CtrlCWhileTheDeviceOpensExitsZero) {
  FakePort port;  // never answers
  const std::string config = patient_proxy_config(port.path(), "tether-stats-patient.json");
  Terminal terminal({"stats", "--config", config, "--device", "silent", "--duration", "60"});
  ASSERT_TRUE(terminal.expect("waiting for the proxy session")) << terminal.screen();
  terminal.type("\x03");
  EXPECT_EQ(terminal.wait_exit(std::chrono::seconds(60)), 0) << terminal.screen();  // the opening ended at once
}

// An outage of the port while stats counts: reported as it happens, and counted in the report's "port"
// (one disconnect, one reconnect, the time down). `tether sim --link` serves the board behind one name;
// ending it unplugs the board, another one plugs it back.
TEST(TetherStats, CountsAnOutageOfItsPort) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string link = ::testing::TempDir() + "/tether-stats-outage-" + std::to_string(::getpid());
  const std::vector<std::string> sim = {firmware("romi-test").string(), "--link", link};
  auto board = std::make_unique<SimBoard>(sim);
  Terminal terminal({"stats", "--port", link, "--passive", "--duration", "600", "--json"});
  ASSERT_TRUE(terminal.expect("counting, ")) << terminal.screen();
  board.reset();  // unplugged
  ASSERT_TRUE(terminal.expect("tether stats: link down: " + link + ": ")) << terminal.screen();
  board = std::make_unique<SimBoard>(sim);
  ASSERT_TRUE(terminal.expect("tether stats: link up after ")) << terminal.screen();
  terminal.type("\x03");
  ASSERT_EQ(terminal.wait_exit(), 0) << terminal.screen();
  const std::string screen = terminal.screen();
  const std::size_t begin = screen.find("{\"device\"");
  ASSERT_NE(begin, std::string::npos) << screen;
  const json report = json::parse(screen.substr(begin, screen.find('\n', begin) - begin));
  EXPECT_EQ(report["port"]["disconnects"], 1);
  EXPECT_EQ(report["port"]["reconnects"], 1);
  EXPECT_TRUE(report["port"]["time_down_ms"].is_number_unsigned()) << report.dump();
}

}  // namespace
}  // namespace tether::cli::testing
