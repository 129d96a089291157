// The codec table proved with a codec the project does not ship: the test-only line-echo codec
// (line_echo/), registered from test code, named in a JSON configuration, parsed and opened by the devices
// library, and driven through `tether shell` (a test build of the command: line_echo/main.cpp).
#include <gtest/gtest.h>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>

#include "line_echo/line_echo.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether_process.hpp"

#ifndef LINE_ECHO_TETHER_BINARY
#error "LINE_ECHO_TETHER_BINARY must name the test build of tether with the line-echo codec"
#endif

namespace tether::cli::testing {
namespace {

using namespace std::chrono_literals;

// The device side: the master of a pty that sends every line it receives back (the port is its slave).
class EchoDevice {
 public:
  EchoDevice() : thread_([this] { run(); }) {}
  ~EchoDevice() {
    stop_ = true;
    thread_.join();
    pty_->close();
  }
  const std::string& path() const { return pty_->slave_path(); }
  std::string received() const {
    const std::lock_guard lock(mutex_);
    return received_;
  }

 private:
  void run() {
    std::string line;
    while (!stop_) {
      char buffer[128];
      boost::system::error_code error;
      const std::size_t size = pty_->read_some(boost::asio::buffer(buffer), 50ms, error);
      if (error == transports::TransportError::timed_out) continue;
      if (error) break;
      for (std::size_t i = 0; i < size; ++i) {
        line += buffer[i];
        if (buffer[i] != '\n') continue;
        {
          const std::lock_guard lock(mutex_);
          received_ += line;
        }
        pty_->write(boost::asio::buffer(line), error);
        line.clear();
      }
    }
  }

  transports::IoThread io_;
  std::shared_ptr<transports::PtyStream> pty_ = transports::PtyStream::open(io_.executor());
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::string received_;
  std::thread thread_;
};

std::string config_text(const std::string& port, const std::string& options = R"({"timeout_ms": 2000})") {
  return R"({"devices": [{"name": "echo", "codec": "line-echo",
             "transport": {"serial": {"path": ")" + port + R"(", "boot_wait_ms": 0}},
             "options": )" + options + "}]}";
}

// A configuration file that goes away with the test.
struct ConfigFile {
  explicit ConfigFile(const std::string& text)
      : path(std::filesystem::temp_directory_path() / ("tether-line-echo-" + std::to_string(::getpid()) + ".json")) {
    std::ofstream(path) << text;
  }
  ~ConfigFile() { std::filesystem::remove(path); }
  std::filesystem::path path;
};

TEST(LineEchoCodec, ARegisteredCodecIsParsedCheckedAndOpenedLikeTheBuiltInOnes) {
  const devices::Codec codec = line_echo::register_line_echo();
  EXPECT_EQ(devices::to_string(codec), "line-echo");
  EchoDevice device;
  const devices::RoverConfig config = devices::parse_config(config_text(device.path()));
  ASSERT_EQ(config.devices.size(), 1u);
  EXPECT_EQ(config.devices[0].codec, codec);
  EXPECT_EQ(config.devices[0].options.get<line_echo::Options>().timeout_ms, 2000u);

  // Its option keys are checked like a built-in codec's, both ways.
  try {
    devices::parse_config(config_text(device.path(), R"({"ping_period_ms": 5})"));
    ADD_FAILURE() << "a proxy option was accepted";
  } catch (const devices::ConfigError& error) {
    EXPECT_EQ(error.detail(), R"(key "ping_period_ms" does not apply to codec line-echo (it is an option of proxy, rpc))");
  }
  try {
    devices::parse_config(R"({"devices": [{"name": "a", "codec": "romi", "transport": {"tcp": {"host": "h",
                              "port": 1}}, "options": {"timeout_ms": 5}}]})");
    ADD_FAILURE() << "a line-echo option was accepted for romi";
  } catch (const devices::ConfigError& error) {
    EXPECT_EQ(error.detail(), R"(key "timeout_ms" does not apply to codec romi (it is an option of line-echo))");
  }
  try {
    devices::parse_config(config_text(device.path(), R"({"timeout_ms": 0})"));
    ADD_FAILURE() << "its own parser's check did not run";
  } catch (const devices::ConfigError& error) {
    EXPECT_EQ(error.path(), "devices[0].options.timeout_ms");
  }

  transports::IoThread io;
  devices::Rover rover = devices::open_rover(config, io.executor());
  const auto client = rover.devices()[0].client.get<line_echo::Client>();
  ASSERT_NE(client, nullptr);
  boost::system::error_code error;
  EXPECT_EQ(client->call("hello", error), "hello");
  EXPECT_FALSE(error) << error.message();
  EXPECT_EQ(client->counters().frames_ok, 1u);
  rover.close();
  EXPECT_EQ(device.received(), "hello\n");
}

TEST(LineEchoCodec, DrivenThroughTetherShellFromAConfiguration) {
  EchoDevice device;
  const ConfigFile config(config_text(device.path()));
  Terminal terminal(LINE_ECHO_TETHER_BINARY, {"shell", "--config", config.path.string(), "--device", "echo"});
  ASSERT_TRUE(terminal.expect("connected to echo in ")) << terminal.screen();
  ASSERT_TRUE(terminal.expect("line-echo> ")) << terminal.screen();
  terminal.type("hello there\n");
  EXPECT_TRUE(terminal.expect("echo hello there")) << terminal.screen();
  terminal.type(":help\n");
  EXPECT_TRUE(terminal.expect("the device sends it back (within 2000 ms)")) << terminal.screen();
  terminal.type(":stats\n");
  EXPECT_TRUE(terminal.expect("codec")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("line-echo")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("frames_ok")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("1")) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
  EXPECT_EQ(device.received(), "hello there\n");
}

// The demo and the bench loop over the codecs' workloads: the test codec's own, registered beside its rows,
// is all they need.
TEST(LineEchoCodec, DrivenThroughTetherDemoAndBenchByItsOwnWorkload) {
  EchoDevice device;
  const ConfigFile config(config_text(device.path()));
  const Outcome demo = run_program(LINE_ECHO_TETHER_BINARY, {"demo", "--config", config.path.string(), "--iterations",
                                                             "5", "--period", "0", "--ber", "0", "--json"});
  ASSERT_EQ(demo.status, 0) << demo.out << demo.err;
  const nlohmann::json report = nlohmann::json::parse(demo.out);
  const nlohmann::json& echo = report.at("devices").at(0);
  EXPECT_EQ(echo.at("codec"), "line-echo");
  EXPECT_EQ(echo.at("operations"), 5);
  EXPECT_EQ(echo.at("successes"), 5);
  EXPECT_EQ(echo.at("wrong"), 0);
  EXPECT_EQ(echo.at("operation"), "line \"op N\" -> the same line back");

  const auto out = std::filesystem::temp_directory_path() / ("tether-line-echo-bench-" + std::to_string(::getpid()));
  const Outcome bench =
      run_program(LINE_ECHO_TETHER_BINARY, {"bench", "--config", config.path.string(), "--iterations", "5", "--sweep",
                                            "ber=0", "--sweep", "rate=max", "--out", out.string(), "--no-plots"});
  EXPECT_EQ(bench.status, 0) << bench.out << bench.err;
  std::ifstream bench_json(out / "bench.json");
  ASSERT_TRUE(bench_json.good()) << bench.out << bench.err;
  const nlohmann::json measured = nlohmann::json::parse(bench_json);
  std::filesystem::remove_all(out);
  ASSERT_EQ(measured.at("points").size(), 1u) << measured.dump();
  const nlohmann::json& point = measured.at("points").at(0);
  EXPECT_EQ(point.at("device"), "echo");
  EXPECT_EQ(point.at("operations"), 5);
  EXPECT_EQ(point.at("successes"), 5);
  EXPECT_TRUE(measured.at("skipped").empty()) << measured.at("skipped").dump();
}

TEST(LineEchoCodec, TheShippedCommandDoesNotKnowIt) {
  const Outcome run = run_tether({"shell", "--port", "/dev/null", "--codec", "line-echo"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--codec needs romi, proxy, proxy-compat, elcano or rpc, got 'line-echo'"), std::string::npos)
      << run.err;
}

}  // namespace
}  // namespace tether::cli::testing
