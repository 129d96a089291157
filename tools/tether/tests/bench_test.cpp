// `tether bench` through the real binary: a short run's bench.json adds up, its CSV, plots and report.html
// are what the issue asks for, `--compare` of a run with itself flags nothing (and a changed run is flagged),
// headless Chromium renders the report with its tables and images, and bad input gets a clear error.
// Outputs are kept in the build tree (bench-test-output/<test>/), screenshots included.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <optional>
#include <utility>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>

#include "tether/testing/child_process.hpp"
#include "tether_process.hpp"

#ifndef BENCH_TEST_OUTPUT_DIR
#error "BENCH_TEST_OUTPUT_DIR must name the folder the bench tests write into"
#endif

namespace tether::cli::testing {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

const std::array<const char*, 5> kPlots = {"latency_cdf.png", "success_vs_ber.png", "p99_vs_rate.png",
                                           "bytes_per_op.png", "cpu_per_op.png"};

// A fresh output folder for this test.
fs::path output_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(BENCH_TEST_OUTPUT_DIR) / (std::string(info->test_suite_name()) + "." + info->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read_text(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream content;
  content << file.rdbuf();
  return content.str();
}

// Width and height of a PNG from its IHDR chunk; {0, 0} when the file is not a PNG.
std::pair<std::uint32_t, std::uint32_t> png_size(const fs::path& path) {
  const std::string bytes = read_text(path);
  if (bytes.size() < 24 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || bytes.compare(12, 4, "IHDR") != 0) {
    return {0, 0};
  }
  const auto be32 = [&](std::size_t at) {
    std::uint32_t value = 0;
    for (std::size_t k = 0; k < 4; ++k) value = (value << 8) | static_cast<unsigned char>(bytes[at + k]);
    return value;
  };
  return {be32(16), be32(20)};
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

// Runs chromium with `argv` to its end: its exit status (nothing after 60 s) and stdout.
std::pair<std::optional<int>, std::string> run_chromium(const std::vector<std::string>& argv) {
  ::tether::testing::ChildProcess process(argv, /*capture_stdout=*/true);
  std::string out;
  while (const auto line = process.read_line(std::chrono::seconds(60))) out += *line + "\n";
  return {process.wait(std::chrono::seconds(60)), out};
}

// avr-size's Berkeley figures for `elf`: {text + data (flash), data + bss (static RAM; its bss counts .noinit)}.
std::pair<long, long> avr_size(const std::string& elf) {
  ::tether::testing::ChildProcess process({"avr-size", elf}, /*capture_stdout=*/true);
  std::string out;
  while (const auto line = process.read_line(std::chrono::seconds(60))) out += *line + "\n";
  EXPECT_EQ(process.wait(std::chrono::seconds(60)), 0) << out;
  std::istringstream rows(out.substr(out.find('\n') + 1));
  long text = 0, data = 0, bss = 0;
  rows >> text >> data >> bss;
  return {text + data, data + bss};
}

// Operations per device and point of the short runs: few, so that the bench tests stay short on a loaded
// 2-core machine; every figure's check holds for any count.
constexpr int kShortRun = 5;

TEST(TetherBench, ShortRunAddsUpWritesCsvPlotsAndReportAndComparesEqualToItself) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const fs::path out = output_dir();
  const Outcome run = run_tether({"bench", "--sweep", "ber=0,1e-3", "--sweep", "rate=100,max", "--iterations", std::to_string(kShortRun),
                                  "--seed", "3", "--saturation", "--out", out.string()});
  ASSERT_EQ(run.status, 0) << run.err << run.out;
  EXPECT_NE(run.out.find("report: " + (out / "report.html").string()), std::string::npos) << run.out;

  const json report = json::parse(read_text(out / "bench.json"));
  EXPECT_EQ(report["parameters"]["seed"], 3);
  EXPECT_EQ(report["parameters"]["iterations"], kShortRun);
  EXPECT_EQ(report["parameters"]["rates_hz"], json::parse(R"([100.0, "max"])"));
  EXPECT_EQ(report["tether_version"], TETHER_VERSION);
  ASSERT_EQ(report["devices"].size(), 6u);
  ASSERT_EQ(report["points"].size(), 6u * 2 * 2);
  for (const json& device : report["devices"]) {
    SCOPED_TRACE(device["device"].get<std::string>());
    ASSERT_FALSE(device["firmware"].empty());
    for (const json& image : device["firmware"]) {
      EXPECT_EQ(image["sha256"].get<std::string>().size(), 64u);
      EXPECT_GT(image["flash_bytes"].get<int>(), 1000);
      // The same figures as avr-size (the proxy image's .noinit was once left out of its RAM: 799 for 816 B).
      const auto [flash, ram] = avr_size(image["path"].get<std::string>());
      EXPECT_EQ(image["flash_bytes"].get<long>(), flash);
      EXPECT_EQ(image["ram_bytes"].get<long>(), ram);
    }
    // --saturation: a ramp per BER, 10 Hz doubling, that stops at the first step not sustained.
    ASSERT_EQ(device["saturation"].size(), 2u) << "one per BER";
    for (const json& saturation : device["saturation"]) {
      EXPECT_EQ(saturation["source"], "ramp");
      const json& ramp = saturation["ramp"];
      ASSERT_GE(ramp.size(), 1u);
      ASSERT_LE(ramp.size(), 7u) << "bounded";
      json last_sustained = nullptr;
      for (std::size_t k = 0; k < ramp.size(); ++k) {
        const json& step = ramp[k];
        EXPECT_EQ(step["rate_hz"].get<double>(), 10.0 * static_cast<double>(1u << k));
        EXPECT_EQ(step["operations"], kShortRun);
        EXPECT_LE(step["successes"].get<int>(), kShortRun);
        EXPECT_EQ(step["sustained"].get<bool>(), k + 1 < ramp.size() || saturation["breaks_down_hz"].is_null())
            << "every step before the last is sustained; the last one is unless the ramp broke down there";
        if (step["sustained"].get<bool>()) last_sustained = step["rate_hz"];
        // Sustained means >= 99 % success and >= 95 % of the asked rate achieved.
        EXPECT_EQ(step["sustained"].get<bool>(),
                  step["successes"].get<int>() == kShortRun && step["achieved_hz"].get<double>() >= 0.95 * step["rate_hz"].get<double>());
      }
      EXPECT_EQ(saturation["sustained_hz"], last_sustained);
      if (saturation["breaks_down_hz"].is_null()) {
        EXPECT_EQ(ramp.size(), 7u) << "a ramp that never broke down ran every step";
        EXPECT_EQ(saturation["breaks_down_because"], "");
      } else {
        EXPECT_EQ(saturation["breaks_down_hz"], ramp.back()["rate_hz"]);
        const bool all_succeeded = ramp.back()["successes"] == kShortRun;
        EXPECT_EQ(saturation["breaks_down_because"], all_succeeded ? "throughput" : "success");
      }
    }
  }
  EXPECT_EQ(report["parameters"]["saturation_ramp"], true);
  for (const json& point : report["points"]) {
    SCOPED_TRACE(point["device"].get<std::string>() + " " + point.dump().substr(0, 120));
    EXPECT_EQ(point["operations"], kShortRun);
    EXPECT_EQ(point["successes"].get<int>() + point["failures"].get<int>() + point["wrong"].get<int>(), kShortRun);
    EXPECT_GT(point["bytes_to_device"].get<int>(), 0);
    // Every confirmed operation brings bytes back; proxy-compat's only come with its 50 ms state stream.
    if (point["device"] != "legacy") {
      EXPECT_GT(point["bytes_from_device"].get<int>(), 0);
    }
    EXPECT_GT(point["cpu_cycles_per_op"].get<double>(), 0.0) << "virtual boards: cycles executed";
    EXPECT_GT(point["utilisation_to_device"].get<double>(), 0.0);
    // The demo images carry the execution witness: commands issued and confirmed, what ran.
    const json& witness = point["exactly_once"];
    ASSERT_TRUE(witness.is_object()) << "the virtual rover's images record what they execute";
    EXPECT_GE(witness["commands"].get<int>(), kShortRun) << "at least one device command per operation";
    EXPECT_LE(witness["confirmed"].get<int>(), witness["commands"].get<int>());
    const json& latency = point["latency_ms"];
    EXPECT_LE(latency["p50"].get<double>(), latency["p90"].get<double>());
    EXPECT_LE(latency["p90"].get<double>(), latency["p99"].get<double>());
    EXPECT_LE(latency["p99"].get<double>(), latency["max"].get<double>());
    const json& cdf = point["latency_cdf"];
    ASSERT_EQ(cdf.size(), static_cast<std::size_t>(kShortRun)) << "every sample when there are fewer than 50";
    for (std::size_t k = 1; k < cdf.size(); ++k) {
      EXPECT_LE(cdf[k - 1][0].get<double>(), cdf[k][0].get<double>()) << "CDF latencies ascend";
      EXPECT_LT(cdf[k - 1][1].get<double>(), cdf[k][1].get<double>()) << "CDF shares ascend";
    }
    EXPECT_EQ(cdf.back()[1].get<double>(), 1.0);
    EXPECT_EQ(cdf.back()[0].get<double>(), latency["max"].get<double>());
  }

  const std::string csv = read_text(out / "bench.csv");
  EXPECT_EQ(count(csv, "\n"), 1u + report["points"].size()) << csv;
  EXPECT_EQ(csv.rfind("device,codec,bit_error_rate,rate_hz,operations,successes", 0), 0u) << csv;

  const std::string html = read_text(out / "report.html");
  for (const char* plot : kPlots) {
    SCOPED_TRACE(plot);
    EXPECT_EQ(png_size(out / plot), std::make_pair(800u, 450u)) << "a PNG of 800 x 450 pixels";
    EXPECT_NE(html.find(std::string("src=\"") + plot + "\""), std::string::npos);
  }
  for (const char* expected : {"Lowest latency", "Fewest bytes", "Most robust under noise", "Lowest device CPU",
                               "<h2>Parameters</h2>", "<h2>Points</h2>"}) {
    EXPECT_NE(html.find(expected), std::string::npos) << expected;
  }

  const std::string path = (out / "bench.json").string();
  const Outcome same = run_tether({"bench", "--compare", path, path});
  EXPECT_EQ(same.status, 0) << same.err << same.out;
  EXPECT_NE(same.out.find("no differences beyond run-to-run noise; 24 point(s) in common"), std::string::npos)
      << same.out;
  EXPECT_EQ(same.out.find(" *"), std::string::npos) << same.out;

  // The same run with one device's latencies tripled and its bytes doubled: flagged, exit status 1.
  json changed = report;
  for (json& point : changed["points"]) {
    if (point["device"] != "arm") continue;
    for (const char* p : {"p50", "p90", "p99"}) point["latency_ms"][p] = point["latency_ms"][p].get<double>() * 3 + 5;
    point["bytes_per_op_to_device"] = point["bytes_per_op_to_device"].get<double>() * 2;
  }
  const fs::path changed_path = out / "changed.json";
  std::ofstream(changed_path) << changed.dump();
  const Outcome different = run_tether({"bench", "--compare", path, changed_path.string(), "--json"});
  EXPECT_EQ(different.status, 1) << different.err << different.out;
  const json comparison = json::parse(different.out);
  EXPECT_EQ(comparison["flagged"], 4 * 3) << "p50, p99 and bytes at arm's four points";
  for (const json& point : comparison["points"]) {
    EXPECT_EQ(point["flagged"]["latency_p50"], point["device"] == "arm") << point;
    EXPECT_FALSE(point["flagged"]["success"].get<bool>()) << point;
  }
}

// Regression: SIGTERM to bench while it plotted left plot_report.py running, writing into the output
// folder after bench had exited. A stand-in plot script that only waits tells when bench reached it.
TEST(TetherBench, StopSignalWhilePlottingEndsThePlotting) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const fs::path out = output_dir();
  const fs::path script = out / "slow_plot.py";
  const fs::path pid_file = out / "plot.pid";
  std::ofstream(script) << "import os, sys, time\n"
                           "open(sys.argv[2] + '/plot.pid.tmp', 'w').write(str(os.getpid()))\n"
                           "os.rename(sys.argv[2] + '/plot.pid.tmp', sys.argv[2] + '/plot.pid')\n"
                           "time.sleep(600)\n"
                           "open(sys.argv[2] + '/late.png', 'w').write('drawn after bench ended')\n";
  ::tether::testing::ChildProcess bench({"env", "TETHER_BENCH_PLOT_SCRIPT=" + script.string(), TETHER_BINARY, "bench",
                                         "--devices", "arm", "--sweep", "ber=0", "--iterations", "3", "--out",
                                         out.string()});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(pid_file) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(fs::exists(pid_file)) << "bench never started the plot script";
  const std::string plot_pid = read_text(pid_file);
  bench.signal(SIGTERM);
  EXPECT_EQ(bench.wait(std::chrono::seconds(30)), 2);
  // The script is gone (or a zombie waiting for init), not sleeping on.
  std::ifstream stat("/proc/" + plot_pid + "/stat");
  std::string fields;
  std::getline(stat, fields);
  const auto state = fields.find(") ");
  EXPECT_TRUE(fields.empty() || (state != std::string::npos && fields[state + 2] == 'Z')) << fields;
}

TEST(TetherBench, HeadlessChromiumRendersTheReportWithItsTablesAndImages) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const fs::path chromium = "/usr/bin/chromium";
  if (!fs::exists(chromium)) GTEST_SKIP() << chromium << " is not installed (Debian: chromium)";
  const fs::path out = output_dir();
  const Outcome run = run_tether({"bench", "--devices", "arm,servos", "--sweep", "ber=0", "--iterations", "5",
                                  "--isolated", "--out", out.string()});
  ASSERT_EQ(run.status, 0) << run.err << run.out;

  const fs::path profile = out / "chromium-profile";
  const std::vector<std::string> common = {chromium.string(),
                                           "--headless",
                                           "--no-sandbox",
                                           "--disable-gpu",
                                           "--disable-background-networking",
                                           "--disable-component-update",
                                           "--disable-sync",
                                           "--no-first-run",
                                           "--user-data-dir=" + profile.string()};
  const std::string url = "file://" + fs::absolute(out / "report.html").string();
  auto dump = common;
  dump.insert(dump.end(), {"--dump-dom", url});
  const auto [dom_status, dom] = run_chromium(dump);
  ASSERT_TRUE(dom_status.has_value()) << "chromium did not finish";
  EXPECT_EQ(*dom_status, 0);
  EXPECT_EQ(count(dom, "<table"), 4u) << "parameters, verdict, devices, points\n" << dom.substr(0, 2000);
  EXPECT_EQ(count(dom, "<img "), 5u) << dom.substr(0, 2000);
  EXPECT_NE(dom.find("Lowest latency"), std::string::npos);

  auto shot = common;
  const fs::path screenshot = out / "report-screenshot.png";
  shot.insert(shot.end(), {"--window-size=1280,2400", "--screenshot=" + screenshot.string(), url});
  const auto shot_status = run_chromium(shot).first;
  ASSERT_TRUE(shot_status.has_value()) << "chromium did not finish";
  EXPECT_EQ(png_size(screenshot), std::make_pair(1280u, 2400u));
}

// Every codec has a read: Romi's ADC, the proxy's PinState read-back (compat: its state stream), the Elcano
// goal round the ring answered by the drive node's sensor report; every answer is checked.
TEST(TetherBench, SensorWorkloadReadsEveryCodecAndChecksTheAnswers) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const fs::path out = output_dir();
  const Outcome run = run_tether({"bench", "--workload", "sensor", "--devices", "arm,servos,legacy,ring", "--sweep",
                                  "ber=0", "--sweep", "rate=max", "--iterations", "6", "--no-plots", "--json",
                                  "--out", out.string()});
  ASSERT_EQ(run.status, 0) << run.err << run.out;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["parameters"]["workload"], "sensor");
  EXPECT_EQ(report["parameters"]["payload"], "demo");
  EXPECT_TRUE(report["skipped"].empty()) << report["skipped"];
  ASSERT_EQ(report["devices"].size(), 4u);
  EXPECT_EQ(report["devices"][0]["operation"], "call A[channel 0..5] -> [0,value 0..1023]");
  EXPECT_EQ(report["devices"][1]["operation"], "DigitalControl{pin 13, toggled} -> PinState (then Ack)");
  EXPECT_EQ(report["devices"][2]["operation"], "DigitalControl{pin 7, toggled} -> its state-stream report");
  EXPECT_NE(report["devices"][3]["operation"].get<std::string>().find("round the ring"), std::string::npos);
  ASSERT_EQ(report["points"].size(), 4u);
  for (const json& point : report["points"]) {
    SCOPED_TRACE(point["device"].get<std::string>());
    EXPECT_EQ(point["workload"], "sensor");
    EXPECT_EQ(point["operations"], 6);
    EXPECT_EQ(point["successes"].get<int>() + point["failures"].get<int>() + point["wrong"].get<int>(), 6);
    // A clean line: every answer right (a failure can only be a timeout on a very loaded machine).
    EXPECT_GT(point["successes"].get<int>(), 0) << point["first_error"];
    EXPECT_EQ(point["wrong"], 0) << point["first_error"];
    EXPECT_GT(point["bytes_from_device"].get<int>(), 0);
  }
  EXPECT_EQ(report["points"][0]["exactly_once"]["commands"], 0) << "a Romi read executes no command";
  EXPECT_GE(report["points"][3]["exactly_once"]["executed"], report["points"][3]["successes"])
      << "each goal answered ends in a drive at the drive node";
}

// --payload small|large: per codec the smallest and the largest operation, their wire bytes apart, with a
// sweep; recorded in bench.json and the CSV.
TEST(TetherBench, PayloadSmallAndLargeDifferInWireBytesAndCombineWithASweep) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const fs::path out = output_dir();
  // The proxy's two differ by ~2 bytes per operation (a ServoControl's two-byte position against a
  // DigitalControl's 0/1); over 12 operations that is ~24 bytes, more than the one or two pings (~9 bytes
  // each, one a second) that may fall in one run and not the other, but not more than re-sends (~12 bytes
  // each), which a loaded machine can cause even on a clean line: compared without them.
  const auto bench = [&](const std::string& payload, const std::string& bers) {
    return run_tether({"bench", "--payload", payload, "--devices", "arm,servos,ring", "--sweep", "ber=" + bers,
                       "--sweep", "rate=max", "--iterations", "12", "--no-plots", "--out", (out / payload).string()});
  };
  const Outcome small = bench("small", "0");
  ASSERT_EQ(small.status, 0) << small.err << small.out;
  const Outcome large = bench("large", "0,1e-4");
  ASSERT_EQ(large.status, 0) << large.err << large.out;
  EXPECT_NE(large.out.find("payload large"), std::string::npos) << large.out;
  const json a = json::parse(read_text(out / "small" / "bench.json"));
  const json b = json::parse(read_text(out / "large" / "bench.json"));
  EXPECT_EQ(a["parameters"]["payload"], "small");
  EXPECT_EQ(b["parameters"]["payload"], "large");
  ASSERT_EQ(a["points"].size(), 3u);
  ASSERT_EQ(b["points"].size(), 3u * 2) << "the sweep's two bit error rates";
  EXPECT_EQ(a["devices"][0]["operation"], "call S[throttle_us,steering_us] -> [0]");
  EXPECT_EQ(b["devices"][0]["operation"], "call L[throttle_us,steering_us,\"32-char label\"] -> [0,32]");
  EXPECT_EQ(a["devices"][1]["operation"], "DigitalControl{pin 13, toggled} -> Ack");
  EXPECT_EQ(b["devices"][1]["operation"], "ServoControl{pin 9, position 128..180} -> Ack");
  for (std::size_t k = 0; k < 3; ++k) {
    const json& s = a["points"][k];
    const json& l = b["points"][k];  // BER 0: the first three
    SCOPED_TRACE(s["device"].get<std::string>());
    EXPECT_EQ(s["payload"], "small");
    EXPECT_EQ(l["payload"], "large");
    EXPECT_EQ(l["bit_error_rate"], 0.0);
    EXPECT_GT(s["successes"].get<int>(), 0) << s["first_error"];
    EXPECT_GT(l["successes"].get<int>(), 0) << l["first_error"];
    EXPECT_EQ(s["wrong"].get<int>() + l["wrong"].get<int>(), 0) << s["first_error"] << l["first_error"];
    if (s["device"] != "servos") {
      EXPECT_GT(l["bytes_per_op_to_device"].get<double>(), s["bytes_per_op_to_device"].get<double>() + 10.0);
    } else if (s["retries"] == 0 && l["retries"] == 0) {
      EXPECT_GT(l["bytes_per_op_to_device"].get<double>(), s["bytes_per_op_to_device"].get<double>());
    }
  }
  // Romi's large request is near the 64-byte frame limit: 55 bytes, S[t,s] ~22.
  EXPECT_GT(b["points"][0]["bytes_per_op_to_device"].get<double>(), 50.0);
  // Elcano's segment also travels one node further: the segment node's drive, then the drive node's report.
  // (>=: a reply late on a loaded machine makes a re-send, which the ring runs again.)
  EXPECT_GE(b["points"][2]["exactly_once"]["executed"], b["points"][2]["successes"]);
  EXPECT_GT(b["points"][2]["exactly_once"]["executed"], 0);
  const std::string csv = read_text(out / "large" / "bench.csv");
  EXPECT_NE(csv.find(",workload,payload\n"), std::string::npos);
  EXPECT_EQ(count(csv, ",servo,large\n"), 6u) << csv;
}

// The hardware path: a config of serial ports, here a `tether sim` board's pty. No simulated CPU or
// firmware figures (the bench cannot see into the board), link use from the configured baud.
TEST(TetherBench, SerialPortConfigMeasuresThroughThePortWithLinkUseFromTheBaud) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const fs::path out = output_dir();
  SimBoard board("romi-rover");
  const fs::path config = out / "rover.json";
  std::ofstream(config) << R"({"name": "bench-pty", "devices": [{"name": "arm", "codec": "romi",
      "transport": {"serial": {"path": ")" << board.pty() << R"(", "baud": 115200, "boot_wait_ms": 0}}}]})";
  const Outcome run = run_tether({"bench", "--config", config.string(), "--sweep", "ber=0", "--sweep", "rate=max",
                                  "--iterations", "6", "--no-plots", "--json", "--out", (out / "run").string()});
  ASSERT_EQ(run.status, 0) << run.err << run.out;
  const json report = json::parse(run.out);
  EXPECT_EQ(report["rover"], "bench-pty");
  ASSERT_EQ(report["devices"].size(), 1u);
  EXPECT_TRUE(report["devices"][0]["firmware"].empty()) << "hardware: no image to describe";
  ASSERT_EQ(report["points"].size(), 1u);
  const json& point = report["points"][0];
  EXPECT_EQ(point["operations"], 6);
  EXPECT_EQ(point["successes"].get<int>() + point["failures"].get<int>() + point["wrong"].get<int>(), 6);
  EXPECT_GT(point["successes"].get<int>(), 0) << point["first_error"];
  EXPECT_TRUE(point["cpu_cycles_per_op"].is_null()) << "no simulated CPU through a port";
  EXPECT_TRUE(point["exactly_once"].is_null());
  // 8N1 at 115200 baud: a byte takes 10 / 115200 s.
  const double expected = point["bytes_to_device"].get<double>() * 10.0 / 115200.0 / point["seconds"].get<double>();
  EXPECT_NEAR(point["utilisation_to_device"].get<double>(), expected, 1e-9 + 1e-6 * expected);
  EXPECT_GT(point["utilisation_from_device"].get<double>(), 0.0);
}

TEST(TetherBench, BadInputGetsAClearError) {
  const fs::path out = output_dir();
  struct Case {
    std::vector<std::string> arguments;
    std::string message;
  };
  const std::string not_a_dir = (out / "file").string();
  std::ofstream(not_a_dir) << "x";
  const std::string malformed = (out / "malformed.json").string();
  std::ofstream(malformed) << "{\"points\": [";
  const std::string pointless = (out / "pointless.json").string();
  std::ofstream(pointless) << R"({"points": [{"device": "arm", "bit_error_rate": 0, "rate_hz": null}]})";
  const std::vector<Case> cases = {
      {{"bench", "--sweep", "noise=1"}, "--sweep: unknown key 'noise' (known: ber, rate)"},
      {{"bench", "--sweep", "ber"}, "--sweep needs KEY=VALUES"},
      {{"bench", "--sweep", "ber=0,lots"}, "--sweep ber: 'lots' is not a bit error rate 0..0.01"},
      {{"bench", "--sweep", "ber=0.5"}, "--sweep ber: '0.5' is not a bit error rate"},
      {{"bench", "--sweep", "rate=fast"}, "--sweep rate: 'fast' is not a rate 0.1..10000 (operations per second) or max"},
      {{"bench", "--sweep", "rate=10,"}, "--sweep rate: '' is not a rate"},
      {{"bench", "--iterations", "0"}, "--iterations needs a number 1..100000"},
      {{"bench", "--iterations", "5", "--duration", "1"}, "--iterations and --duration exclude each other"},
      {{"bench", "--payload", "huge"}, "--payload needs small, large or demo, got 'huge'"},
      {{"bench", "--payload"}, "--payload needs small, large or demo, got ''"},
      {{"bench", "--workload", "temperature"}, "--workload needs servo or sensor, got 'temperature'"},
      {{"bench", "--out", not_a_dir + "/sub"}, "--out " + not_a_dir + "/sub: "},
      {{"bench", "--compare", malformed, malformed}, malformed + ": invalid JSON"},
      {{"bench", "--compare", not_a_dir + ".missing", malformed}, not_a_dir + ".missing: No such file or directory"},
      {{"bench", "--compare", pointless, pointless}, pointless + ".points[0]: no \"operations\""},
      {{"bench", "--compare", malformed}, "--compare needs two files"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments.back());
    const Outcome run = run_tether(c.arguments);
    EXPECT_EQ(run.status, 2) << run.out;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
  }
  // A proxy whose config inits no digital pin has no small operation: skipped, and alone a clear error.
  if (fs::exists(firmware("proxy"))) {
    const fs::path config = out / "servos-only.json";
    std::ofstream(config) << R"({"name": "servos-only", "devices": [{"name": "servos", "codec": "proxy",
        "transport": {"virtual": {"firmware": "proxy", "pacing": "real_time", "seed": 2}},
        "options": {"inits": [{"kind": "servo", "pin": 9, "safe_position": 90}]}}]})";
    const Outcome run = run_tether({"bench", "--config", config.string(), "--payload", "small", "--sweep", "ber=0",
                                    "--iterations", "1", "--no-plots", "--out", (out / "small").string()});
    EXPECT_EQ(run.status, 2);
    EXPECT_NE(run.err.find("no selected device has the servo workload with the small payload; servos: its config "
                           "inits no digital pin for the small operation"),
              std::string::npos)
        << run.err;
  }
  // An unknown device is named, before anything runs long.
  if (fs::exists(firmware("elcano-node"))) {
    const Outcome run = run_tether({"bench", "--devices", "arm,wheel", "--out", (out / "run").string()});
    EXPECT_EQ(run.status, 2);
    EXPECT_NE(run.err.find("no device named 'wheel'"), std::string::npos) << run.err;
  }
}

}  // namespace
}  // namespace tether::cli::testing
