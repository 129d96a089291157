// Recording with the command: `--record FILE` on call and shell, `monitor --tap --write`, `demo --record`
// under noise; the files read back with the capture reader and with Debian's tshark; never overwritten
// without --force; a capture file that cannot be written is an error before the device opens.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tether/testing/child_process.hpp"
#include "tether/transports/pcapng.hpp"
#include "capture_files.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

namespace fs = std::filesystem;
using transports::Capture;
using transports::CaptureDirection;

// A fresh file name in the test's temporary folder (removed first).
std::string capture_file(const std::string& name) { return fresh_capture_file("tether-record-" + name); }

std::string text_of(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

// `tshark -r FILE -T fields -e FIELDS...`: one line per packet, fields separated by tabs.
std::vector<std::string> tshark_fields(const std::string& file, const std::vector<std::string>& fields) {
  std::string command = "tshark -r '" + file + "' -T fields";
  for (const auto& field : fields) command += " -e " + field;
  command += " 2>/dev/null";
  std::vector<std::string> lines;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return lines;
  std::string text;
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) text.append(buffer, got);
  ::pclose(pipe);
  std::size_t start = 0;
  for (std::size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1) {
    lines.push_back(text.substr(start, end - start));
  }
  return lines;
}

#define REQUIRE_TSHARK()                                                                   \
  do {                                                                                     \
    if (!fs::exists("/usr/bin/tshark")) GTEST_SKIP() << "tshark is not installed (tools/setup deps)"; \
  } while (false)

TEST(TetherRecord, CallRecordsBothDirectionsReadableByTheReaderAndTshark) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("call");
  const Outcome run = run_tether({"call", "--virtual", "romi-test", "--record", file, "e"});
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "[0,1,2]\n");
  const Capture capture = read_capture_file(file);
  EXPECT_EQ(capture.application, "tether " TETHER_VERSION);
  ASSERT_EQ(capture.interfaces.size(), 1u);
  EXPECT_EQ(capture.interfaces[0].name, "romi-test");
  EXPECT_EQ(capture.interfaces[0].description, "tether codec=romi baud=- transport=virtual");
  // The request, then its answer: whole frames, in order, with their directions.
  std::vector<const transports::CapturePacket*> frames;
  for (const auto& packet : capture.packets) {
    if (packet.comment.empty()) frames.push_back(&packet);
  }
  ASSERT_GE(frames.size(), 2u);
  EXPECT_EQ(frames[0]->direction, CaptureDirection::outbound);
  EXPECT_EQ(text_of(frames[0]->data).substr(0, 3), "#e:");
  EXPECT_EQ(text_of(frames[0]->data).substr(frames[0]->data.size() - 2), "\r\n");
  EXPECT_EQ(frames.back()->direction, CaptureDirection::inbound);
  EXPECT_EQ(text_of(frames.back()->data).substr(0, 9), "#e[0,1,2]");
  for (std::size_t i = 1; i < capture.packets.size(); ++i) {
    EXPECT_GE(capture.packets[i].timestamp_us, capture.packets[i - 1].timestamp_us);
  }

  REQUIRE_TSHARK();
  const auto lines = tshark_fields(file, {"frame.interface_name", "frame.packet_flags_direction", "frame.comment"});
  ASSERT_EQ(lines.size(), capture.packets.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto& packet = capture.packets[i];
    // tshark shows the direction bits as the flags word's hex (1 inbound, 2 outbound).
    const std::string direction = packet.direction == CaptureDirection::unknown
                                      ? ""
                                      : "0x0000000" + std::to_string(static_cast<int>(packet.direction));
    EXPECT_EQ(lines[i], "romi-test\t" + direction + "\t" + packet.comment) << i;
  }
  const auto descriptions = tshark_fields(file, {"frame.interface_description"});
  ASSERT_FALSE(descriptions.empty());
  EXPECT_EQ(descriptions[0], "tether codec=romi baud=- transport=virtual");
}

TEST(TetherRecord, AnExistingFileIsNeverOverwrittenWithoutForce) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("force");
  { std::ofstream(file) << "precious"; }
  const Outcome refused = run_tether({"call", "--virtual", "romi-test", "--record", file, "e"});
  EXPECT_EQ(refused.status, 2);
  EXPECT_NE(refused.err.find(file + ": File exists (--force overwrites it)"), std::string::npos) << refused.err;
  EXPECT_EQ(fs::file_size(file), 8u);
  const Outcome forced = run_tether({"call", "--virtual", "romi-test", "--record", file, "--force", "e"});
  EXPECT_EQ(forced.status, 0) << forced.err;
  EXPECT_FALSE(read_capture_file(file).packets.empty());

  const Outcome alone = run_tether({"call", "--virtual", "romi-test", "--force", "e"});
  EXPECT_EQ(alone.status, 2);
  EXPECT_NE(alone.err.find("--force applies to --record only"), std::string::npos) << alone.err;
  const Outcome nowhere = run_tether({"call", "--virtual", "romi-test", "--record", "/nonexistent/x.pcapng", "e"});
  EXPECT_EQ(nowhere.status, 2);
  EXPECT_NE(nowhere.err.find("/nonexistent/x.pcapng: No such file or directory"), std::string::npos) << nowhere.err;
}

TEST(TetherRecord, AFailedOpenLeavesNoCaptureBehind) {
  // `call` waits for a missing port within its budget, trying again: the capture the first try created must
  // not fail the next one ("File exists"), and none is left when the port never comes.
  const std::string file = capture_file("no-port");
  const std::string port = (fs::path(::testing::TempDir()) / "tether-record-no-such-port").string();
  const Outcome waited = run_tether({"call", "--port", port, "--timeout", "300", "--record", file, "e"});
  EXPECT_EQ(waited.status, 2);
  EXPECT_NE(waited.err.find(port + ": No such file or directory"), std::string::npos) << waited.err;
  EXPECT_EQ(waited.err.find("File exists"), std::string::npos) << waited.err;
  EXPECT_FALSE(fs::exists(file));
  const Outcome once = run_tether({"stats", "--port", port, "--no-reconnect", "--record", file, "--duration", "1"});
  EXPECT_EQ(once.status, 2);
  EXPECT_EQ(once.err.find("File exists"), std::string::npos) << once.err;
  EXPECT_FALSE(fs::exists(file));
}

TEST(TetherRecord, ACaptureFileThatCannotBeCreatedIsNotAPortToWaitFor) {
  const std::string port = (fs::path(::testing::TempDir()) / "tether-record-no-such-port").string();
  const auto started = std::chrono::steady_clock::now();
  const Outcome run = run_tether({"call", "--port", port, "--timeout", "60000", "--record", "/nonexistent/x.pcapng", "e"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("/nonexistent/x.pcapng: No such file or directory"), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find("waited"), std::string::npos) << run.err;  // failed at once, not after the budget
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(50));
}

TEST(TetherRecord, AConfigurationsTopLevelRecordAppliesToTheDeviceACommandOpens) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("top-level");
  const fs::path config = fs::path(::testing::TempDir()) / "tether-record-top-level.json";
  std::ofstream(config) << R"({"record": ")" << file << R"(", "devices": [{"name": "arm", "codec": "romi",
      "transport": {"virtual": {"firmware": ")" << TETHER_FIRMWARE_DIR << R"(/romi-test.elf"}}}]})";
  const Outcome run = run_tether({"call", "--config", config.string(), "--device", "arm", "e"});
  fs::remove(config);
  ASSERT_EQ(run.status, 0) << run.err;
  const Capture capture = read_capture_file(file);
  ASSERT_EQ(capture.interfaces.size(), 1u);
  EXPECT_EQ(capture.interfaces[0].name, "arm");
  EXPECT_FALSE(capture.packets.empty());
}

TEST(TetherRecord, AnOutageOfThePortIsRecordedAsLinkEvents) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("outage");
  const std::string link = ::testing::TempDir() + "/tether-record-outage-" + std::to_string(::getpid());
  const std::vector<std::string> sim = {firmware("romi-test").string(), "--link", link};
  auto board = std::make_unique<SimBoard>(sim);
  Terminal terminal({"shell", "--port", link, "--record", file});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  board.reset();  // unplugged
  ASSERT_TRUE(terminal.expect("link down: ")) << terminal.screen();
  board = std::make_unique<SimBoard>(sim);  // back
  ASSERT_TRUE(terminal.expect("link up after ")) << terminal.screen();
  terminal.type(":quit\n");
  ASSERT_EQ(terminal.wait_exit(), 0) << terminal.screen();
  std::vector<std::string> events;
  for (const auto& packet : read_capture_file(file).packets) {
    if (packet.link_event()) events.push_back(packet.comment);
  }
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0], "link: down");
  // The re-opened port's boot: how long until ready, and how that was known.
  EXPECT_TRUE(matches(events[1], "link: up ready after # ms (*)")) << events[1];
}

TEST(TetherRecord, StatsCountsWhatWasRecorded) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("stats");
  const Outcome run = run_tether({"stats", "--virtual", "romi-test", "--record", file, "--json", "--duration", "0.5"});
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("\"record\":{\"file\":\"" + file + "\""), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\"dropped\":0"), std::string::npos) << run.out;
}

// Noise on every link of the demo rover: every device is an interface of the one file, damaged frames stay
// frames (the dissector judges their CRC), and whatever is not a whole frame of its codec's framing is marked
// unframed, in stream order (how many depends on where the noise hit: the deterministic count is the
// fault-injecting stream's test, simulator/fault-injecting-stream/tests).
TEST(TetherRecord, DemoUnderNoiseRecordsEveryDeviceFramedOrMarkedUnframed) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const std::string file = capture_file("demo");
  const Outcome run = run_tether({"demo", "--iterations", "10", "--period", "10", "--ber", "0.01", "--no-reset",
                                  "--seed", "3", "--record", file});
  ASSERT_LE(run.status, 1) << run.err;
  const Capture capture = read_capture_file(file);
  ASSERT_EQ(capture.interfaces.size(), 6u);
  std::vector<std::string> codecs;
  for (const auto& interface : capture.interfaces) codecs.push_back(interface.word("codec"));
  EXPECT_EQ(codecs, (std::vector<std::string>{"romi", "proxy", "proxy-compat", "rpc", "elcano", "elcano"}));
  EXPECT_EQ(capture.interfaces[5].word("generation"), "D");
  std::size_t unframed = 0;
  std::vector<std::size_t> per_interface(capture.interfaces.size());
  for (const auto& packet : capture.packets) {
    ++per_interface[packet.interface];
    if (packet.unframed()) {
      ++unframed;
      continue;
    }
    ASSERT_FALSE(packet.data.empty());
    const std::string codec = capture.interfaces[packet.interface].word("codec");
    const std::string bytes = text_of(packet.data);
    if (codec == "romi") {
      EXPECT_EQ(bytes.front(), '#') << bytes;
      EXPECT_EQ(bytes.find('#', 1), std::string::npos) << bytes;
    }
    if (codec == "elcano") {
      EXPECT_NE(std::string("DSGX").find(bytes.front()), std::string::npos) << bytes;
    }
    const bool lines = codec == "romi" || codec == "elcano";
    const char end = lines ? '\n' : '\0';
    // One frame: its end byte last and nowhere else (after a COBS frame's leading 0x00s).
    const std::size_t body = lines ? 0 : bytes.find_first_not_of('\0');
    ASSERT_NE(body, std::string::npos) << codec;
    EXPECT_EQ(bytes.find(end, body), bytes.size() - 1) << codec;
  }
  for (std::size_t i = 0; i < per_interface.size(); ++i) EXPECT_GT(per_interface[i], 10u) << capture.interfaces[i].name;

  REQUIRE_TSHARK();
  const auto comments = tshark_fields(file, {"frame.comment"});
  ASSERT_EQ(comments.size(), capture.packets.size());
  std::size_t tshark_unframed = 0;
  for (const auto& comment : comments) tshark_unframed += comment.rfind("unframed", 0) == 0 ? 1u : 0u;
  EXPECT_EQ(tshark_unframed, unframed);
}

// `demo` and `bench` take the device commands' ring-file limits: a demo's capture past the size limit goes
// on in the ring's next file, each a complete capture of every device.
TEST(TetherRecord, DemoRecordsIntoRingFilesWithTheDeviceCommandsLimits) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const std::string file = capture_file("demo-ring");
  const std::string second = (fs::path(file).parent_path() / "tether-record-demo-ring.1.pcapng").string();
  fs::remove(second);
  const Outcome run = run_tether({"demo", "--iterations", "10", "--period", "10", "--ber", "0", "--no-reset",
                                  "--record", file, "--record-max-bytes", "4096", "--record-files", "2"});
  ASSERT_EQ(run.status, 0) << run.err;
  for (const std::string& each : {file, second}) {
    const Capture capture = read_capture_file(each);
    EXPECT_EQ(capture.interfaces.size(), 6u) << each;
    EXPECT_FALSE(capture.packets.empty()) << each;
  }
  // A usage error writes nothing, not even the output folder.
  const fs::path out = fs::path(::testing::TempDir()) / "tether-record-bench-usage";
  fs::remove_all(out);
  const Outcome alone = run_tether({"bench", "--record-files", "3", "--iterations", "1", "--out", out.string()});
  EXPECT_EQ(alone.status, 2);
  EXPECT_NE(alone.err.find("--record-files needs --record FILE"), std::string::npos) << alone.err;
  EXPECT_FALSE(fs::exists(out));
  const Outcome bad = run_tether({"demo", "--record", file, "--record-max-bytes", "12"});
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("--record-max-bytes needs bytes (4096 or more), got '12'"), std::string::npos) << bad.err;
}

// `monitor --tap --write`: an application's session through the tap is recorded, and replaying the file
// prints what the tap printed (times aside).
TEST(TetherRecord, TapWritesTheSessionAndReplayPrintsWhatTheTapPrinted) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("tap");
  ::tether::testing::ChildProcess tap({TETHER_BINARY, "monitor", "--virtual", "romi-test", "--tap", "--write", file},
                                      true);
  const auto ready = tap.read_line(std::chrono::seconds(30));
  ASSERT_TRUE(ready && ready->starts_with("PTY /dev/")) << ready.value_or("(nothing)");
  const Outcome call = run_tether({"call", "--port", ready->substr(4), "e"});
  EXPECT_EQ(call.status, 0) << call.err;
  std::vector<std::string> printed;
  for (int i = 0; i < 2; ++i) {
    const auto line = tap.read_line(std::chrono::seconds(20));
    ASSERT_TRUE(line);
    printed.push_back(line->substr(line->find(' ')));  // without the time
  }
  tap.signal(SIGTERM);
  EXPECT_EQ(tap.wait(std::chrono::seconds(20)), 0);
  const Capture capture = read_capture_file(file);
  ASSERT_EQ(capture.interfaces.size(), 1u);
  EXPECT_EQ(capture.interfaces[0].word("codec"), "romi");
  const Outcome replay = run_tether({"replay", file});
  ASSERT_EQ(replay.status, 0) << replay.err;
  std::vector<std::string> replayed;
  for (const auto& line : replay.lines()) replayed.push_back(line.substr(line.find(' ')));
  EXPECT_EQ(replayed, printed);
}

TEST(TetherReplay, PrintsACaptureAsTheTapWould) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("replay");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  const Outcome replay = run_tether({"replay", file});
  ASSERT_EQ(replay.status, 0) << replay.err;
  ASSERT_EQ(replay.lines().size(), 2u) << replay.out;
  EXPECT_TRUE(matches(replay.lines()[0], "0.000 host->device frame~e id *")) << replay.lines()[0];
  EXPECT_TRUE(matches(replay.lines()[1], "#.# device->host frame~e[0,1,2] id *")) << replay.lines()[1];
  const Outcome json = run_tether({"replay", file, "--json"});
  ASSERT_EQ(json.status, 0) << json.err;
  EXPECT_TRUE(matches(json.lines()[0], R"({"t_ms":0.0,"direction":"host->device","kind":"frame",*})")) << json.out;
}

TEST(TetherReplay, BadFilesAreErrorsNamingTheOffset) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string file = capture_file("replay-bad");
  ASSERT_EQ(run_tether({"call", "--virtual", "romi-test", "--record", file, "e"}).status, 0);
  const std::string cut = capture_file("replay-cut");
  {
    std::ifstream whole(file, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 10);
  }
  const Outcome truncated = run_tether({"replay", cut});
  EXPECT_EQ(truncated.status, 2);
  EXPECT_TRUE(matches(truncated.err, "tether replay: " + cut + ": offset #: block of type 0x00000006 truncated*"))
      << truncated.err;
  const Outcome text = run_tether({"replay", TETHER_SOURCE_DIR "/README.md"});
  EXPECT_EQ(text.status, 2);
  EXPECT_NE(text.err.find("offset 0: not a pcapng file"), std::string::npos) << text.err;
  const Outcome missing = run_tether({"replay"});
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.err.find("no capture file given"), std::string::npos);
  const Outcome device = run_tether({"replay", file, "--device", "other"});
  EXPECT_EQ(device.status, 2);
  EXPECT_NE(device.err.find("no device 'other' (devices: \"romi-test\")"), std::string::npos) << device.err;
}

}  // namespace
}  // namespace tether::cli::testing
