// `tether replay FILE --as-device`: a session of `tether call` / `tether send` recorded against a virtual
// board, then played on a pty to the same command with other ids: it gets the recorded answers; a request
// the recording lacks is a line on stderr and the device's answer to an unknown request.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "tether/testing/child_process.hpp"
#include "tether/transports/pcapng.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

namespace fs = std::filesystem;

std::string temporary(const std::string& name) {
  const fs::path file = fs::path(::testing::TempDir()) / ("tether-replay-device-" + name);
  fs::remove(file);
  return file.string();
}

std::string file_text(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// `tether replay ARGS...` playing a device in the background, its stderr into a file.
class PlayedDevice {
 public:
  explicit PlayedDevice(const std::vector<std::string>& arguments, const std::string& name)
      : errors_(temporary(name + ".stderr")) {
    std::string command = "exec '" TETHER_BINARY "' replay";
    for (const auto& argument : arguments) command += " '" + argument + "'";
    command += " 2>'" + errors_ + "'";
    process_ = std::make_unique<::tether::testing::ChildProcess>(std::vector<std::string>{"/bin/sh", "-c", command},
                                                                 true);
    const auto line = process_->read_line(std::chrono::seconds(30));
    if (line && line->starts_with("PTY /dev/")) pty_ = line->substr(4);
  }
  const std::string& pty() const { return pty_; }
  std::string errors() const { return file_text(errors_); }
  ::tether::testing::ChildProcess& process() { return *process_; }

 private:
  std::string errors_;
  std::unique_ptr<::tether::testing::ChildProcess> process_;
  std::string pty_;
};

TEST(TetherReplayAsDevice, RomiCallGetsTheRecordedAnswerUnderItsOwnId) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = temporary("romi.pcapng");
  const Outcome recorded = run_tether({"call", "--virtual", "romi-test", "--record", file, "--id", "5", "e"});
  ASSERT_EQ(recorded.status, 0) << recorded.err;
  const std::string link = temporary("romi.link");
  PlayedDevice device({file, "--as-device", "--link", link}, "romi");
  ASSERT_FALSE(device.pty().empty());
  EXPECT_EQ(fs::read_symlink(link), device.pty());
  // Another id: the answer carries it, with its CRC (the client drops any other).
  const Outcome call = run_tether({"call", "--port", link, "--id", "200", "--json", "e"});
  EXPECT_EQ(call.status, 0) << call.err;
  EXPECT_NE(call.out.find("[0,1,2]"), std::string::npos) << call.out;
  EXPECT_NE(call.out.find("\"id\":200"), std::string::npos) << call.out;
  // The recording ended once the answer was read: the replay ends by itself, its link removed.
  EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0) << device.errors();
  EXPECT_EQ(device.errors(), "");
  EXPECT_FALSE(fs::exists(fs::symlink_status(link)));
}

TEST(TetherReplayAsDevice, ARequestTheRecordingLacksIsALineOnStderrAndAnsweredAsAnUnknownOpcode) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = temporary("romi-mismatch.pcapng");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  PlayedDevice device({file, "--as-device"}, "romi-mismatch");
  ASSERT_FALSE(device.pty().empty());
  const Outcome wrong = run_tether({"call", "--port", device.pty(), "--id", "9", "a[1]"});
  EXPECT_EQ(wrong.status, 2) << wrong.out << wrong.err;
  EXPECT_EQ(wrong.out, "[-16]\n") << wrong.err;
  EXPECT_TRUE(matches(device.errors(),
                      "tether replay: request 1 does not match the recording: expected 'e' (recorded request 1 of 1, "
                      "at # ms), got 'a[1]'\n"))
      << device.errors();
  // The recorded request still comes next.
  const Outcome right = run_tether({"call", "--port", device.pty(), "e"});
  EXPECT_EQ(right.status, 0) << right.err;
  EXPECT_EQ(right.out, "[0,1,2]\n");
  EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0) << device.errors();
}

// A capture written by hand: one Romi link, `#e:05` answered 20 ms later, then a log line 800 ms after it.
std::string romi_capture_with_a_late_log_line(const std::string& name) {
  using transports::CaptureDirection;
  namespace pcapng = transports::pcapng;
  const auto bytes = [](std::string_view text) { return std::vector<std::uint8_t>(text.begin(), text.end()); };
  const std::uint64_t t0 = 1700000000000000;
  std::vector<std::vector<std::uint8_t>> blocks = {
      pcapng::section_header("tether test"),
      pcapng::interface_description("arm", "tether codec=romi baud=115200 transport=serial"),
      pcapng::enhanced_packet(0, t0, CaptureDirection::outbound, bytes("#e:05cd\r\n"), ""),
      pcapng::enhanced_packet(0, t0 + 20000, CaptureDirection::inbound, bytes("#e[0,1,2]:05c7\r\n"), ""),
      pcapng::enhanced_packet(0, t0 + 820000, CaptureDirection::inbound, bytes("#!bye:xxxx\r\n"), "")};
  const std::string file = temporary(name);
  std::ofstream out(file, std::ios::binary);
  for (const auto& block : blocks) {
    out.write(reinterpret_cast<const char*>(block.data()), static_cast<std::streamsize>(block.size()));
  }
  return file;
}

// The host closed the port before the recording's last frame came: nobody reads it, and the replay still
// ends (it waited for it to be read, for ever).
TEST(TetherReplayAsDevice, EndsWhenTheHostLeftTheLastFramesUnread) {
  const std::string file = romi_capture_with_a_late_log_line("late-log.pcapng");
  PlayedDevice device({file, "--as-device"}, "late-log");
  ASSERT_FALSE(device.pty().empty());
  const Outcome call = run_tether({"call", "--port", device.pty(), "--id", "77", "e"});
  EXPECT_EQ(call.status, 0) << call.err;
  EXPECT_EQ(call.out, "[0,1,2]\n");
  EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0) << device.errors();
  EXPECT_EQ(device.errors(), "");
}

TEST(TetherReplayAsDevice, LoopPlaysTheRecordingAgainUntilASignal) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = temporary("romi-loop.pcapng");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  PlayedDevice device({file, "--as-device", "--loop"}, "romi-loop");
  ASSERT_FALSE(device.pty().empty());
  for (int i = 0; i < 3; ++i) {
    const Outcome call = run_tether({"call", "--port", device.pty(), "e"});
    EXPECT_EQ(call.status, 0) << i << call.err;
    EXPECT_EQ(call.out, "[0,1,2]\n") << i;
  }
  device.process().signal(SIGINT);
  EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0);
  EXPECT_EQ(device.errors(), "");
}

TEST(TetherReplayAsDevice, ProxySendGetsTheRecordedAcksUnderItsOwnMessageIds) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const std::string file = temporary("proxy.pcapng");
  const std::vector<std::string> messages = {"servo-init", "pin=9", "safe-position=90", "servo-control", "pin=9",
                                             "position=120"};
  std::vector<std::string> record = {"send", "--virtual", "proxy", "--record", file};
  record.insert(record.end(), messages.begin(), messages.end());
  const Outcome recorded = run_tether(record);
  ASSERT_EQ(recorded.status, 0) << recorded.err;
  PlayedDevice device({file, "--as-device"}, "proxy");
  ASSERT_FALSE(device.pty().empty());
  std::vector<std::string> send = {"send", "--port", device.pty(), "--codec", "proxy"};
  send.insert(send.end(), messages.begin(), messages.end());
  const Outcome live = run_tether(send);
  EXPECT_EQ(live.status, 0) << live.err;
  ASSERT_EQ(live.lines().size(), 2u) << live.out;
  EXPECT_TRUE(matches(live.lines()[0], "servo-init: acked, message id #, 1 attempt; pin 9 = 90")) << live.out;
  EXPECT_TRUE(matches(live.lines()[1], "servo-control: acked, message id #, 1 attempt; pin 9 = 120")) << live.out;
  EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0) << device.errors();
  EXPECT_EQ(device.errors(), "");
}

TEST(TetherReplayAsDevice, RpcCallAndStreamGetTheRecordedRepliesUnderTheirOwnIds) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  const std::string schema = fs::path(firmware("rpc-example")).replace_extension(".proto").string();
  const std::vector<std::vector<std::string>> sessions = {{"MoveJoint", "joint=1", "angle_cdeg=3000"},
                                                          {"--count", "3", "--period", "50", "Watch"}};
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    const std::string file = temporary("rpc" + std::to_string(i) + ".pcapng");
    std::vector<std::string> record = {"call", "--virtual", "rpc-example", "--record", file};
    record.insert(record.end(), sessions[i].begin(), sessions[i].end());
    const Outcome recorded = run_tether(record);
    ASSERT_EQ(recorded.status, 0) << recorded.err;
    PlayedDevice device({file, "--as-device"}, "rpc" + std::to_string(i));
    ASSERT_FALSE(device.pty().empty());
    std::vector<std::string> call = {"call", "--port", device.pty(), "--codec", "rpc", "--schema", schema};
    call.insert(call.end(), sessions[i].begin(), sessions[i].end());
    // A new client: new message ids, which the replies, acks and stream messages must carry.
    const Outcome live = run_tether(call);
    EXPECT_EQ(live.status, 0) << live.err;
    EXPECT_EQ(live.out, recorded.out);
    EXPECT_EQ(device.process().wait(std::chrono::seconds(30)), 0) << device.errors();
    EXPECT_EQ(device.errors(), "");
  }
}

TEST(TetherReplayAsDevice, UsageErrors) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = temporary("usage.pcapng");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  const Outcome loop = run_tether({"replay", file, "--loop"});
  EXPECT_EQ(loop.status, 2);
  EXPECT_NE(loop.err.find("--loop applies to --as-device only"), std::string::npos) << loop.err;
  const Outcome utc = run_tether({"replay", file, "--as-device", "--utc"});
  EXPECT_EQ(utc.status, 2);
  EXPECT_NE(utc.err.find("--utc does not apply to --as-device"), std::string::npos) << utc.err;
  const Outcome device = run_tether({"replay", file, "--as-device", "--device", "other"});
  EXPECT_EQ(device.status, 2);
  EXPECT_NE(device.err.find("no device 'other'"), std::string::npos) << device.err;
}

}  // namespace
}  // namespace tether::cli::testing
