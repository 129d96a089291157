// `tether replay FILE --against-virtual IMAGE`: sessions recorded with the command on virtual boards, replayed
// against the same image (the same answers), another image of the codec (the differing frame printed), and
// captures edited by the test (a frame taken out, a periodic frame put in, a second link); bad requests are
// errors with exit status 2. The replay runs on the board's clock, so these runs are deterministic.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/transports/pcapng.hpp"
#include "capture_files.hpp"
#include "proxy_frames.hpp"
#include "tether_process.hpp"
#include "tether_proxy.pb.h"

namespace tether::cli::testing {
namespace {

namespace fs = std::filesystem;
using transports::Capture;
using transports::CaptureDirection;
using transports::CapturePacket;

// A fresh file name in the test's temporary folder (removed first).
std::string replay_file(const std::string& name) { return fresh_capture_file("tether-replay-" + name); }

// Writes `capture` to `file` (what the test changed in it included).
void replay_write(const Capture& capture, const std::string& file) {
  std::ofstream stream(file, std::ios::binary);
  const auto put = [&](const std::vector<std::uint8_t>& block) {
    stream.write(reinterpret_cast<const char*>(block.data()), static_cast<std::streamsize>(block.size()));
  };
  put(transports::pcapng::section_header(capture.application));
  for (const auto& interface : capture.interfaces) put(transports::pcapng::interface_description(interface.name, interface.description));
  for (const CapturePacket& packet : capture.packets) {
    put(transports::pcapng::enhanced_packet(packet.interface, packet.timestamp_us, packet.direction, packet.data, packet.comment));
  }
}

// The device->host frames of `capture`, in order.
std::vector<std::size_t> answers(const Capture& capture) {
  std::vector<std::size_t> indexes;
  for (std::size_t i = 0; i < capture.packets.size(); ++i) {
    if (capture.packets[i].direction == CaptureDirection::inbound && !capture.packets[i].unframed()) indexes.push_back(i);
  }
  return indexes;
}

// The messageId of a proxy frame: of the host's message, or of the device's ack.
std::optional<std::uint32_t> replay_proxy_id(const std::vector<std::uint8_t>& bytes, bool from_host) {
  LinkCounters counters;
  proxy::Decoder<256> decoder(proxy::Integrity::crc16, counters);
  for (const std::uint8_t byte : bytes) {
    if (decoder.feed(byte) != DecodeStatus::frame) continue;
    const ByteView payload = decoder.frame();
    if (from_host) {
      proxy::ArduinoIn message;
      if (message.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) return message.messageid();
    } else {
      proxy::ArduinoOut message;
      if (message.ParseFromArray(payload.data(), static_cast<int>(payload.size())) && message.has_ack()) {
        return message.ack().messageid();
      }
    }
    return std::nullopt;
  }
  return std::nullopt;
}

// A proxy session: the client's Reset handshake, a servo initialised and moved. The client's first Ping races
// the device's restart after the Reset: lost while it reboots, it is taken once its receiver is back. The
// recording's board ran behind the wall clock by as much as the machine's load made it, the replay's runs on
// the recorded offsets, so a message the recording shows lost may come late enough in the replay to be taken:
// the host's messages the device never acked are taken out, for a session whose outcome does not depend on
// the load it was recorded under.
std::string record_proxy_session(const std::string& name) {
  const std::string file = replay_file(name);
  const Outcome run = run_tether({"send", "--virtual", "proxy", "--record", file, "servo-init", "pin=9",
                                  "safe-position=90", "servo-control", "pin=9", "position=120"});
  EXPECT_EQ(run.status, 0) << run.err;
  Capture capture = read_capture_file(file);
  std::set<std::uint32_t> acked;
  for (const CapturePacket& packet : capture.packets) {
    if (packet.direction != CaptureDirection::inbound) continue;
    if (const auto id = replay_proxy_id(packet.data, false)) acked.insert(*id);
  }
  std::erase_if(capture.packets, [&](const CapturePacket& packet) {
    if (packet.direction != CaptureDirection::outbound) return false;
    const auto id = replay_proxy_id(packet.data, true);
    return id && acked.count(*id) == 0;
  });
  fs::remove(file);
  replay_write(capture, file);
  return file;
}

TEST(TetherReplayAgainstVirtual, RomiSessionAgainstItsOwnImageIsTheSame) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = replay_file("romi-same");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "g[2]"}).status, 0);
  const Outcome replay = run_tether({"replay", file, "--against-virtual", "romi-test"});
  EXPECT_EQ(replay.status, 0) << replay.out << replay.err;
  // Two log lines and the answer.
  EXPECT_EQ(replay.out, "same: 3 frames the same, 0 differ\n");
  const Outcome json = run_tether({"replay", file, "--against-virtual", "romi-test", "--json"});
  EXPECT_EQ(json.status, 0) << json.err;
  ASSERT_EQ(json.lines().size(), 1u) << json.out;
  const auto summary = nlohmann::json::parse(json.lines()[0])["summary"];
  EXPECT_EQ(summary["result"], "same");
  EXPECT_EQ(summary["same"], 3);
  EXPECT_EQ(summary["differ"], 0);

  // A frame the end of the recording cut is counted, not compared.
  Capture capture = read_capture_file(file);
  CapturePacket cut = capture.packets.back();
  ASSERT_EQ(cut.direction, CaptureDirection::inbound);
  const std::string partial = "#!lo";
  cut.data.assign(partial.begin(), partial.end());
  cut.comment = "unframed: cut at close";
  capture.packets.push_back(cut);
  const std::string edited = replay_file("romi-cut");
  replay_write(capture, edited);
  const Outcome replay_cut = run_tether({"replay", edited, "--against-virtual", "romi-test"});
  EXPECT_EQ(replay_cut.status, 0) << replay_cut.out << replay_cut.err;
  EXPECT_EQ(replay_cut.out,
            "ignored: 1 recorded, 0 new frames: cut at close: a partial frame where the recording or the run ended\n"
            "same: 3 frames the same, 0 differ; 1 recorded and 0 new frames ignored\n");
}

TEST(TetherReplayAgainstVirtual, RomiSessionAgainstAnotherImagePrintsTheChangedAnswer) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  TETHER_REQUIRE_FIRMWARE("romi-blink");
  const std::string file = replay_file("romi-other");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  // romi-blink has no `e`: it answers the request's id with an error code.
  const Outcome replay = run_tether({"replay", file, "--against-virtual", "romi-blink"});
  EXPECT_EQ(replay.status, 1) << replay.out << replay.err;
  const auto lines = replay.lines();
  ASSERT_EQ(lines.size(), 3u) << replay.out;
  EXPECT_TRUE(matches(lines[0], "#.# changed~frame~e[0,1,2] id *")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "#.#~now~frame~e[-#] id *")) << lines[1];
  EXPECT_EQ(lines[2], "different: 0 frames the same, 1 differ (1 changed, 0 recorded only, 0 new only)");
  const Outcome json = run_tether({"replay", file, "--against-virtual", "romi-blink", "--json"});
  EXPECT_EQ(json.status, 1);
  ASSERT_EQ(json.lines().size(), 2u) << json.out;
  const auto difference = nlohmann::json::parse(json.lines()[0]);
  EXPECT_EQ(difference["difference"], "changed");
  EXPECT_EQ(difference["recorded"]["values"], nlohmann::json::parse("[0,1,2]"));
  EXPECT_EQ(difference["recorded"]["id"], difference["new"]["id"]);
  EXPECT_EQ(nlohmann::json::parse(json.lines()[1])["summary"]["result"], "different");
}

// A recorded answer taken out of the capture: the board's answer is new; a frame added: recorded only. Both
// found by the alignment, the rest the same.
TEST(TetherReplayAgainstVirtual, FramesOnlyOneSideHasAreAligned) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = replay_file("romi-edit");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "g[3]"}).status, 0);
  Capture capture = read_capture_file(file);
  const auto frames = answers(capture);
  ASSERT_EQ(frames.size(), 4u);  // three log lines, the answer
  CapturePacket extra = capture.packets[frames[3]];
  const std::string added = "#!surprise:xxxx\r\n";
  extra.data.assign(added.begin(), added.end());
  capture.packets.erase(capture.packets.begin() + static_cast<long>(frames[1]));  // `log 2`
  capture.packets.push_back(extra);
  const std::string edited = replay_file("romi-edited");
  replay_write(capture, edited);
  const Outcome replay = run_tether({"replay", edited, "--against-virtual", "romi-test"});
  EXPECT_EQ(replay.status, 1) << replay.out << replay.err;
  const auto lines = replay.lines();
  ASSERT_EQ(lines.size(), 3u) << replay.out;
  EXPECT_TRUE(matches(lines[0], "#.# new-only~log~log 2*")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "#.# recorded-only log~surprise*")) << lines[1];
  EXPECT_EQ(lines[2], "different: 3 frames the same, 2 differ (0 changed, 1 recorded only, 1 new only)");
}

TEST(TetherReplayAgainstVirtual, ProxySessionIsTheSameWithItsSessionIdsSetAside) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const std::string file = record_proxy_session("proxy-same");
  const Outcome replay = run_tether({"replay", file, "--against-virtual", "proxy"});
  EXPECT_EQ(replay.status, 0) << replay.out << replay.err;
  // The boot's and the Reset's ResetEvent, each with the sessionId of its boot (and, should the session have
  // lasted 5 s, the ArduinoInfo of each run counted on a line of its own).
  const auto lines = replay.lines();
  EXPECT_NE(std::find(lines.begin(), lines.end(),
                      "compared in part: 2 recorded, 2 new frames: resetEvent: compared without its sessionId (new at "
                      "every boot)"),
            lines.end())
      << replay.out;
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(matches(lines.back(), "same: # frames the same, 0 differ*")) << lines.back();
}

// A recorded ArduinoInfo is ignored and counted; a pinState taken out is the board's new frame.
TEST(TetherReplayAgainstVirtual, ProxyPeriodicInfoIsIgnoredAndCountedAndAMissingFrameShown) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const std::string file = record_proxy_session("proxy-edit");
  Capture capture = read_capture_file(file);
  const auto frames = answers(capture);
  ASSERT_FALSE(frames.empty());
  CapturePacket info;
  proxy::ArduinoOut message;
  message.mutable_info()->set_sessionid(12345);
  const std::string bytes = proxy_frame(message);
  info.data.assign(bytes.begin(), bytes.end());
  // The pinState of the servo's move out, an info in.
  proxy::ArduinoOut moved;
  moved.mutable_pinstate()->set_pin(9);
  moved.mutable_pinstate()->set_value(120);
  const std::string moved_bytes = proxy_frame(moved);
  const auto pin = std::find_if(frames.begin(), frames.end(), [&](std::size_t index) {
    const auto& data = capture.packets[index].data;
    return std::string(data.begin(), data.end()) == moved_bytes;
  });
  ASSERT_NE(pin, frames.end());
  capture.packets[*pin].data = info.data;
  const std::string edited = replay_file("proxy-edited");
  replay_write(capture, edited);
  const Outcome replay = run_tether({"replay", edited, "--against-virtual", "proxy"});
  EXPECT_EQ(replay.status, 1) << replay.out << replay.err;
  // Info frames the session itself had (one every 5 s; a loaded machine may have made it that long) are on
  // both sides, ignored alike.
  const Outcome printed = run_tether({"replay", file, "--json"});
  ASSERT_EQ(printed.status, 0) << printed.err;
  std::size_t infos = 0;
  for (const auto& line : printed.lines()) infos += line.find("\"type\":\"info\"") != std::string::npos ? 1u : 0u;
  // A ping the client wrote while the device restarted after its Reset is lost on both runs, or on neither,
  // as the recorded timing has it: the note that says so is not this test's.
  std::vector<std::string> lines = replay.lines();
  std::erase_if(lines, [](const std::string& line) { return line.starts_with("note: "); });
  ASSERT_EQ(lines.size(), 4u) << replay.out;
  EXPECT_TRUE(matches(lines[0], "#.# new-only~message~pinState pin: 9 value: 120")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "ignored: " + std::to_string(infos + 1) +
                                    " recorded, # new frames: info: sent every 5 s (how many depends on the run's length)"))
      << lines[1];
  EXPECT_EQ(lines[2], "compared in part: 2 recorded, 2 new frames: resetEvent: compared without its sessionId (new at "
                      "every boot)");
  EXPECT_TRUE(matches(lines[3], "different: # frames the same, 1 differ (0 changed, 0 recorded only, 1 new only); # "
                                "recorded and # new frames ignored"))
      << lines[3];
}

TEST(TetherReplayAgainstVirtual, RpcSessionAgainstItsImageAndAnother) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  TETHER_REQUIRE_FIRMWARE("rpc-servos");
  const std::string file = replay_file("rpc");
  ASSERT_EQ(run_tether({"call", "--virtual", "rpc-example", "--record", file, "MoveJoint", "joint=1", "angle_cdeg=-4500"})
                .status,
            0);
  const Outcome same = run_tether({"replay", file, "--against-virtual", "rpc-example"});
  EXPECT_EQ(same.status, 0) << same.out << same.err;
  ASSERT_FALSE(same.lines().empty());
  EXPECT_TRUE(matches(same.lines().back(), "same: # frames the same, 0 differ")) << same.out;
  EXPECT_NE(same.out.find("compared in part: 1 recorded, 1 new frames: device-hello: compared without its session"),
            std::string::npos)
      << same.out;
  // Another schema: its hello names another hash.
  const Outcome other = run_tether({"replay", file, "--against-virtual", "rpc-servos"});
  EXPECT_EQ(other.status, 1) << other.out << other.err;
  EXPECT_NE(other.out.find("changed       message  device-hello"), std::string::npos) << other.out;
  EXPECT_NE(other.out.find("(not this schema"), std::string::npos) << other.out;
}

// Elcano's virtual devices are rings: the image runs as `--virtual` runs it, a ring of one board set up by the
// codec (it answers each drive message with a sensor report).
TEST(TetherReplayAgainstVirtual, ElcanoLoneBoardSessionAndAChangedReport) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  const std::string file = replay_file("elcano");
  ::tether::testing::ChildProcess shell({"sh", "-c",
                                         "printf 'D{s 50}{a 25}\\nD{s -20}{a 5}\\n' | exec \"$0\" shell --virtual "
                                         "elcano-node --record \"$1\"",
                                         TETHER_BINARY, file},
                                        /*capture_stdout=*/true);
  std::string out;
  while (const auto line = shell.read_line(std::chrono::seconds(60))) out += *line + "\n";
  ASSERT_EQ(shell.wait(std::chrono::seconds(20)), 0) << out;
  const Outcome same = run_tether({"replay", file, "--against-virtual", "elcano-node"});
  EXPECT_EQ(same.status, 0) << same.out << same.err;
  EXPECT_EQ(same.out, "same: 2 frames the same, 0 differ\n");

  Capture capture = read_capture_file(file);
  const auto frames = answers(capture);
  ASSERT_EQ(frames.size(), 2u);
  auto& report = capture.packets[frames[1]].data;
  const std::string recorded(report.begin(), report.end());
  ASSERT_EQ(recorded.substr(0, 11), "S{s -20}{a ") << recorded;
  report[11] = static_cast<std::uint8_t>('6');  // {a 5} -> {a 6}
  const std::string edited = replay_file("elcano-edited");
  replay_write(capture, edited);
  const Outcome changed = run_tether({"replay", edited, "--against-virtual", "elcano-node"});
  EXPECT_EQ(changed.status, 1) << changed.out << changed.err;
  const auto lines = changed.lines();
  ASSERT_EQ(lines.size(), 3u) << changed.out;
  EXPECT_TRUE(matches(lines[0], "#.# changed~message~S{s -20}{a 6}*")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "#.#~now~message~S{s -20}{a 5}*")) << lines[1];
  EXPECT_EQ(lines[2], "different: 1 frame the same, 1 differ (1 changed, 0 recorded only, 0 new only)");
}

TEST(TetherReplayAgainstVirtual, BadRequestsAreErrors) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  TETHER_REQUIRE_FIRMWARE("proxy");
  const std::string file = replay_file("bad");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);

  const Outcome no_link = run_tether({"replay", file, "--device", "arm", "--against-virtual", "romi-test"});
  EXPECT_EQ(no_link.status, 2);
  EXPECT_NE(no_link.err.find(file + ": no device 'arm' (devices: \"romi-test\")"), std::string::npos) << no_link.err;

  const Outcome missing = run_tether({"replay", file, "--against-virtual", "romi-nothing"});
  EXPECT_EQ(missing.status, 2);
  EXPECT_TRUE(matches(missing.err, "tether replay: firmware image not found: */romi-nothing.elf: No such file or "
                                   "directory\n"))
      << missing.err;

  const Outcome other_codec = run_tether({"replay", file, "--against-virtual", "proxy"});
  EXPECT_EQ(other_codec.status, 2);
  EXPECT_NE(other_codec.err.find("proxy.elf is a proxy image, and device 'romi-test' of " + file + " speaks romi"),
            std::string::npos)
      << other_codec.err;

  const Outcome no_image = run_tether({"replay", file, "--against-virtual"});
  EXPECT_EQ(no_image.status, 2);
  EXPECT_NE(no_image.err.find("--against-virtual needs an image"), std::string::npos) << no_image.err;
  const Outcome settle = run_tether({"replay", file, "--settle", "10"});
  EXPECT_EQ(settle.status, 2);
  EXPECT_NE(settle.err.find("--settle applies to --against-virtual only"), std::string::npos) << settle.err;
  const Outcome utc = run_tether({"replay", file, "--utc", "--against-virtual", "romi-test"});
  EXPECT_EQ(utc.status, 2);
  EXPECT_NE(utc.err.find("--utc does not apply to --against-virtual"), std::string::npos) << utc.err;

  // Two links: one must be named; the named one is replayed.
  Capture capture = read_capture_file(file);
  ASSERT_EQ(capture.interfaces.size(), 1u);
  capture.interfaces.push_back(capture.interfaces[0]);
  capture.interfaces[1].name = "second";
  const std::size_t packets = capture.packets.size();
  for (std::size_t i = 0; i < packets; ++i) {
    CapturePacket copy = capture.packets[i];
    copy.interface = 1;
    capture.packets.push_back(copy);
  }
  const std::string two = replay_file("two-links");
  replay_write(capture, two);
  const Outcome unnamed = run_tether({"replay", two, "--against-virtual", "romi-test"});
  EXPECT_EQ(unnamed.status, 2);
  EXPECT_NE(unnamed.err.find(two + ": 2 device links (\"romi-test\", \"second\"): name one with --device"),
            std::string::npos)
      << unnamed.err;
  const Outcome named = run_tether({"replay", two, "--device", "second", "--against-virtual", "romi-test"});
  EXPECT_EQ(named.status, 0) << named.out << named.err;
  EXPECT_EQ(named.out, "same: 1 frame the same, 0 differ\n");

  // A link whose host sent nothing.
  Capture quiet = read_capture_file(file);
  std::erase_if(quiet.packets, [](const CapturePacket& packet) { return packet.direction == CaptureDirection::outbound; });
  const std::string silent = replay_file("silent");
  replay_write(quiet, silent);
  const Outcome nothing = run_tether({"replay", silent, "--against-virtual", "romi-test"});
  EXPECT_EQ(nothing.status, 2);
  EXPECT_NE(nothing.err.find("device 'romi-test' has no host->device bytes to send"), std::string::npos) << nothing.err;
}

}  // namespace
}  // namespace tether::cli::testing
