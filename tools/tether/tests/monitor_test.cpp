// `tether monitor`: a device scripted by the test on a pty says exactly what is checked (good frames, a
// log line, damaged frames, garbage), and a virtual proxy board announces its boot.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fake_port.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "proxy_frames.hpp"
#include "tether_process.hpp"
#include "tether_proxy.pb.h"

namespace tether::cli::testing {
namespace {

using nlohmann::json;

// Everything after the timestamp: "kind    detail".
std::vector<std::string> without_stamps(const std::vector<std::string>& lines) {
  std::vector<std::string> rest;
  for (const std::string& line : lines) {
    const std::size_t space = line.find(' ');
    EXPECT_TRUE(space != std::string::npos && matches(line.substr(0, space), "#.#")) << line;
    rest.push_back(space == std::string::npos ? line : line.substr(space + 1));
  }
  return rest;
}

// Romi: responses, a log line, a response with a bad CRC, garbage before a frame.
constexpr std::string_view kRomiTraffic =
    "#e[0,1,2]:00dc\r\n"
    "#!motor: ready:xxxx\r\n"
    "#e[0,1,2]:00dd\r\n"
    "zz#a[0]:00e7\r\n";

TEST(TetherMonitor, RomiFramesLogLinesAndErrorsWithTimestamps) {
  FakePort device;
  device.send(kRomiTraffic);
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "3"});
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> expected = {
      "frame    e[0,1,2] id 00",
      "log      motor: ready",
      "error    -4 crc mismatch (opcode e, id 00)",
      "resync   skipped bytes to the next frame start",
      "frame    a[0] id 00",
  };
  EXPECT_EQ(without_stamps(run.lines()), expected) << run.out;
}

TEST(TetherMonitor, RomiJsonLines) {
  FakePort device;
  device.send(kRomiTraffic);
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "2", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const auto lines = run.lines();
  ASSERT_EQ(lines.size(), 2u) << run.out;
  const json frame = json::parse(lines[0]);
  EXPECT_TRUE(frame["t_ms"].is_number());
  EXPECT_GE(frame["t_ms"].get<double>(), 0.0);
  EXPECT_EQ(frame["kind"], "frame");
  EXPECT_EQ(frame["opcode"], "e");
  EXPECT_EQ(frame["id"], 0);
  EXPECT_EQ(frame["payload"], "e[0,1,2]");
  EXPECT_EQ(frame["values"], json::parse("[0,1,2]"));
  const json log = json::parse(lines[1]);
  EXPECT_EQ(log["kind"], "log");
  EXPECT_EQ(log["text"], "motor: ready");
}

// Regression: a frame with an empty payload made the monitor abort (std::out_of_range from substr). The
// reference firmware sends `#!#:xxxx`: it logs the offending byte before an envelope error, and `#`
// restarts the frame.
constexpr std::string_view kEmptyPayloadTraffic =
    "#:xxxx\r\n"
    "#!#:xxxx\r\n"
    "#a[0]:00e7\r\n";

TEST(TetherMonitor, RomiFrameWithAnEmptyPayload) {
  FakePort device;
  device.send(kEmptyPayloadTraffic);
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "3"});
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> expected = {
      "frame    (empty) (manual)",
      "resync   skipped bytes to the next frame start",
      "frame    (empty) (manual)",
      "frame    a[0] id 00",
  };
  EXPECT_EQ(without_stamps(run.lines()), expected) << run.out;
}

TEST(TetherMonitor, RomiFrameWithAnEmptyPayloadAsJson) {
  FakePort device;
  device.send(kEmptyPayloadTraffic);
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "3", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  std::vector<json> frames;
  for (const std::string& line : run.lines()) {
    const json object = json::parse(line);
    if (object["kind"] == "frame") frames.push_back(object);
  }
  ASSERT_EQ(frames.size(), 3u) << run.out;
  EXPECT_EQ(frames[0]["payload"], "");
  EXPECT_EQ(frames[0]["manual"], true);
  EXPECT_FALSE(frames[0].contains("values"));
  EXPECT_EQ(frames[1]["payload"], "");
  EXPECT_EQ(frames[2]["values"], json::parse("[0]"));
}

TEST(TetherMonitor, UtcTimestamps) {
  FakePort device;
  device.send(kRomiTraffic);
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "1", "--utc"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(matches(run.out, "#-#-#T#:#:#.#Z frame    e[0,1,2] id 00\n")) << run.out;
  EXPECT_EQ(run.out.find('Z'), 23u) << run.out;  // 2024-05-01T12:00:00.123Z
}

TEST(TetherMonitor, ProxyMessagesAndCrcErrors) {
  FakePort device;
  proxy::ArduinoOut ack;
  ack.mutable_ack()->set_messageid(7);
  proxy::ArduinoOut pin;
  pin.mutable_pinstate()->set_pin(9);
  pin.mutable_pinstate()->set_value(120);
  std::string damaged = proxy_frame(ack);
  damaged[3] = static_cast<char>(damaged[3] ^ 0x01);  // a payload bit: the CRC no longer matches
  device.send(proxy_frame(ack) + damaged + proxy_frame(pin));
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--codec", "proxy", "--count", "2"});
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> expected = {
      "message  ack messageId: 7",
      "error    CRC mismatch",
      "message  pinState pin: 9 value: 120",
  };
  EXPECT_EQ(without_stamps(run.lines()), expected) << run.out;
}

// Device text never reaches the terminal raw: escape sequences, the bell and NUL in a Romi log line come
// out as \xNN (a NUL no longer cuts the line); JSON keeps the text itself.
TEST(TetherMonitor, DeviceTextIsEscapedForTheTerminal) {
  FakePort device;
  static constexpr char kLine[] = "#!\x1b[2Jclear\x07 bell \0 nul \xff end:xxxx\r\n";
  device.send(std::string_view(kLine, sizeof kLine - 1));
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--count", "1"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(without_stamps(run.lines()), std::vector<std::string>{"log      \\x1b[2Jclear\\x07 bell \\x00 nul \\xff end"})
      << run.out;
  EXPECT_EQ(run.out.find('\x1b'), std::string::npos);
}

// A proxy Error whose text is not UTF-8 is shown as the message it is, not as undecodable, and without
// libprotobuf's complaint on stderr.
TEST(TetherMonitor, ProxyErrorWhoseTextIsNotUtf8IsShown) {
  FakePort device;
  proxy::ArduinoOut error;
  error.mutable_error()->set_text("bad \xff byte");
  error.mutable_error()->set_level(proxy::Error::FATAL);
  device.send(proxy_frame(error));
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--codec", "proxy", "--count", "1"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(without_stamps(run.lines()), std::vector<std::string>{R"(message  error text: "bad \\xff byte" level: FATAL)"})
      << run.out;
  EXPECT_EQ(run.err.find("UTF-8"), std::string::npos) << run.err;
}

TEST(TetherMonitor, ProxyJson) {
  FakePort device;
  proxy::ArduinoOut info;
  info.mutable_info()->set_sessionid(1234);
  info.mutable_info()->set_pingfailsafetriggered(true);
  device.send(proxy_frame(info));
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--codec", "proxy", "--count", "1", "--json"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json message = json::parse(run.out);
  EXPECT_EQ(message["kind"], "message");
  EXPECT_EQ(message["type"], "info");
  EXPECT_EQ(message["fields"], json::parse(R"({"sessionId":1234,"pingFailsafeTriggered":true})"));
}

TEST(TetherMonitor, VirtualProxyBoardAnnouncesItsBoot) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  // The firmware sends ResetEvent at the end of its setup; the monitor sends nothing.
  const Outcome run = run_tether({"monitor", "--virtual", "proxy", "--count", "1"});
  EXPECT_EQ(run.status, 0) << run.err;
  const auto lines = without_stamps(run.lines());
  ASSERT_EQ(lines.size(), 1u) << run.out;
  EXPECT_TRUE(matches(lines[0], "message  resetEvent sessionId: #")) << lines[0];
}

TEST(TetherMonitor, ElcanoForwardsWhatItDoesNotCapture) {
  FakePort ring;  // the test is both the previous and the next board
  ring.send("S{s 1}{a 2}{b 3}{p 4,5}\nD{s 9}{a 1}\n");
  const Outcome run =
      run_tether({"monitor", "--port", ring.path(), "--codec", "elcano", "--capture", "sensor", "--count", "2"});
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> expected = {
      "captured S{s 1}{a 2}{b 3}{p 4,5}",
      "forwarded D{s 9}{a 1}",
  };
  EXPECT_EQ(without_stamps(run.lines()), expected) << run.out;
  // The drive message went on to the next board, whitespace-stripped like the reference; the captured
  // sensor message did not.
  EXPECT_EQ(ring.read_until('\n'), "D{s9}{a1}\n");
}

// A message that ends without a required field is dropped at its line end; the next line is read from its
// first byte, so no "resync" line (it used to appear at the next header although nothing was skipped).
TEST(TetherMonitor, ElcanoErrorAtALineEndIsNotFollowedByAResync) {
  FakePort ring;
  ring.send("D{s 1}\nD{s 9}{a 1}\n");
  const Outcome run = run_tether({"monitor", "--port", ring.path(), "--codec", "elcano", "--count", "1"});
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<std::string> expected = {
      "error    inval_comb",
      "forwarded D{s 9}{a 1}",
  };
  EXPECT_EQ(without_stamps(run.lines()), expected) << run.out;
  EXPECT_EQ(ring.read_until('\n'), "D{s9}{a1}\n");
}

TEST(TetherMonitor, DurationEndsAQuietMonitor) {
  FakePort device;
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--duration", "0.2"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "");
}

// A pipe that holds `fill` already and that nobody reads: the next write to it blocks. Not closed on exec,
// so a child started through `sh` can take it as its stdout.
struct FullPipe {
  int read_end = -1;
  int write_end = -1;
  FullPipe() {
    int ends[2];
    EXPECT_EQ(::pipe(ends), 0);
    read_end = ends[0];
    write_end = ends[1];
    (void)::fcntl(write_end, F_SETPIPE_SZ, 4096);
    const int flags = ::fcntl(write_end, F_GETFL);
    (void)::fcntl(write_end, F_SETFL, flags | O_NONBLOCK);
    const std::string block(4096, 'x');
    while (::write(write_end, block.data(), block.size()) > 0 || errno == EINTR) {
    }
    (void)::fcntl(write_end, F_SETFL, flags);  // the child's writes block, as on any full pipe
  }
  ~FullPipe() {
    ::close(read_end);
    ::close(write_end);
  }
  // `tether ARGS...` with stdout on this pipe and stderr on the child's captured stdout.
  std::vector<std::string> tether_argv(const std::vector<std::string>& arguments) const {
    // Through /dev/fd: a shell redirects only descriptors 0-9 with `>&N`, and the test's may be higher.
  std::vector<std::string> argv = {"sh", "-c", "exec \"$0\" \"$@\" 2>&1 >/dev/fd/" + std::to_string(write_end),
                                     TETHER_BINARY};
    argv.insert(argv.end(), arguments.begin(), arguments.end());
    return argv;
  }
};

std::string stderr_of(::tether::testing::ChildProcess& run) {
  std::string err;
  while (const auto line = run.read_line(std::chrono::seconds(30))) err += *line + "\n";
  return err;
}

// A stdout nobody reads does not outlast --duration: the monitor gives its lines up, says why, exits 2.
TEST(TetherMonitor, StdoutNobodyReadsDoesNotOutlastTheDuration) {
  FakePort device;
  device.send("#!one:xxxx\r\n");
  const FullPipe pipe;
  ::tether::testing::ChildProcess run(pipe.tether_argv({"monitor", "--port", device.path(), "--duration", "0.5"}),
                                      /*capture_stdout=*/true);
  const std::string err = stderr_of(run);
  EXPECT_EQ(run.wait(std::chrono::seconds(20)), 2) << err;
  EXPECT_NE(err.find("tether monitor: the output could not be written: its reader stopped reading"),
            std::string::npos)
      << err;
}

// Nor a stop signal. (Sent once the monitor has had time to block on its first line; should it come
// before, the monitor ends all the same, having lost nothing: either way it must end.)
TEST(TetherMonitor, StdoutNobodyReadsDoesNotOutlastAStopSignal) {
  FakePort device;
  device.send("#!one:xxxx\r\n");
  const FullPipe pipe;
  ::tether::testing::ChildProcess run(pipe.tether_argv({"monitor", "--port", device.path()}), /*capture_stdout=*/true);
  // The signal goes when tether handles it: sent before, it would meet the default action (a loaded
  // machine can take longer than any fixed wait to start a sanitized tether).
  ASSERT_TRUE(run.wait_until_catching(SIGTERM, std::chrono::seconds(60)));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the monitor blocked on its full stdout
  run.signal(SIGTERM);
  const std::string err = stderr_of(run);
  const std::optional<int> status = run.wait(std::chrono::seconds(20));
  ASSERT_TRUE(status.has_value()) << "still running 20 s after SIGTERM";
  EXPECT_TRUE(*status == 2 || *status == 0) << *status << "\n" << err;
  if (*status == 2) {
    EXPECT_NE(err.find("its reader stopped reading"), std::string::npos) << err;
  }
}

TEST(TetherMonitor, LinkFailureExitsTwo) {
  auto device = std::make_unique<FakePort>();
  const std::string path = device->path();
  ::tether::testing::ChildProcess monitor({TETHER_BINARY, "monitor", "--port", path, "--json", "--no-reconnect"}, true);
  device->send("#a[0]:00e7\r\n");
  const auto line = monitor.read_line(std::chrono::seconds(20));
  ASSERT_TRUE(line);
  EXPECT_EQ(json::parse(*line)["payload"], "a[0]");
  device.reset();  // the device goes away (the pty closes)
  EXPECT_EQ(monitor.wait(std::chrono::seconds(20)), 2);
}

// `monitor --tap`: a romi client (`tether call`) talks to a virtual romi-test through the tap's pty; the
// calls succeed and both directions are decoded, each line with its direction.
TEST(TetherMonitor, TapPassesASessionThroughAndDecodesBothDirections) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  ::tether::testing::ChildProcess tap({TETHER_BINARY, "monitor", "--virtual", "romi-test", "--tap"}, true);
  const auto ready = tap.read_line(std::chrono::seconds(30));
  ASSERT_TRUE(ready && ready->starts_with("PTY /dev/")) << ready.value_or("(nothing)");
  const std::string pty = ready->substr(4);

  const Outcome first = run_tether({"call", "--port", pty, "e"});
  EXPECT_EQ(first.status, 0) << first.err;
  EXPECT_EQ(first.out, "[0,1,2]\n");
  const Outcome second = run_tether({"call", "--port", pty, "s[2,3]"});
  EXPECT_EQ(second.status, 0) << second.err;
  EXPECT_EQ(second.out, "[0,5]\n");

  // Each call: its request host->device, then the answer device->host.
  const std::vector<std::string> patterns = {
      "#.# host->device frame    e id *",
      "#.# device->host frame    e[0,1,2] id *",
      "#.# host->device frame    s[2,3] id *",
      "#.# device->host frame    s[0,5] id *",
  };
  std::vector<std::string> lines;
  for (std::size_t i = 0; i < patterns.size(); ++i) {
    const auto line = tap.read_line(std::chrono::seconds(20));
    ASSERT_TRUE(line) << "after " << lines.size() << " lines";
    lines.push_back(*line);
    EXPECT_TRUE(matches(*line, patterns[i])) << *line;
  }
  tap.signal(SIGTERM);
  EXPECT_EQ(tap.wait(std::chrono::seconds(20)), 0);
}

// `monitor --tap` outlives an outage of the device's port even when the application writes meanwhile (its
// bytes are dropped, as on a wire to an unplugged board): the next session through the tap is answered.
TEST(TetherMonitor, TapRidesOutAnOutageWhileTheApplicationWrites) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string link = ::testing::TempDir() + "/tether-tap-outage-" + std::to_string(::getpid());
  const std::vector<std::string> sim = {firmware("romi-test").string(), "--link", link};
  auto board = std::make_unique<SimBoard>(sim);
  ::tether::testing::ChildProcess tap({TETHER_BINARY, "monitor", "--port", link, "--tap"}, true);
  const auto ready = tap.read_line(std::chrono::seconds(30));
  ASSERT_TRUE(ready && ready->starts_with("PTY /dev/")) << ready.value_or("(nothing)");
  const std::string pty = ready->substr(4);
  const Outcome before = run_tether({"call", "--port", pty, "e"});
  EXPECT_EQ(before.status, 0) << before.err;

  board.reset();  // unplugged
  const Outcome during = run_tether({"call", "--port", pty, "--timeout", "300", "e"});  // written into the tap
  EXPECT_NE(during.status, 0);
  board = std::make_unique<SimBoard>(sim);  // back: the tap re-opens it within about a second
  Outcome after;
  // A request the tap drops before the port is back gets no answer (Romi calls are not re-sent): try again.
  for (int attempt = 0; attempt < 30; ++attempt) {
    after = run_tether({"call", "--port", pty, "e"});
    if (after.status == 0 || tap.wait(std::chrono::milliseconds(0)).has_value()) break;
  }
  EXPECT_EQ(after.status, 0) << after.err;
  EXPECT_EQ(after.out, "[0,1,2]\n");
  tap.signal(SIGTERM);
  EXPECT_EQ(tap.wait(std::chrono::seconds(20)), 0);
}

TEST(TetherMonitor, TapJsonLinesCarryTheDirection) {
  FakePort device;
  ::tether::testing::ChildProcess tap({TETHER_BINARY, "monitor", "--port", device.path(), "--tap", "--json"}, true);
  const auto ready = tap.read_line(std::chrono::seconds(30));
  ASSERT_TRUE(ready);
  const std::string pty = json::parse(*ready)["pty"];
  // The application's side: the test opens the tap's pty like a serial port.
  transports::IoThread io;
  const auto application = transports::SerialPortStream::open(io.executor(), pty, transports::SerialOptions());
  const std::string request = "#e:xxxx\r\n";
  application->write(boost::asio::buffer(request));
  EXPECT_EQ(device.read_until('\n'), request);  // passed on unchanged
  device.send("#e[0,1,2]:00dc\r\n");
  std::string answer;
  while (answer.find('\n') == std::string::npos) {
    char buffer[64];
    boost::system::error_code error;
    const std::size_t size =
        application->read_some(boost::asio::buffer(buffer), std::chrono::seconds(20), error);
    ASSERT_FALSE(error) << error.message();
    answer.append(buffer, size);
  }
  EXPECT_EQ(answer, "#e[0,1,2]:00dc\r\n");
  const auto to_device = tap.read_line(std::chrono::seconds(20));
  ASSERT_TRUE(to_device);
  const json request_line = json::parse(*to_device);
  EXPECT_EQ(request_line["direction"], "host->device");
  EXPECT_EQ(request_line["kind"], "frame");
  EXPECT_EQ(request_line["payload"], "e");
  EXPECT_EQ(request_line["manual"], true);
  const auto to_host = tap.read_line(std::chrono::seconds(20));
  ASSERT_TRUE(to_host);
  const json answer_line = json::parse(*to_host);
  EXPECT_EQ(answer_line["direction"], "device->host");
  EXPECT_EQ(answer_line["kind"], "frame");
  EXPECT_EQ(answer_line["values"], json::parse("[0,1,2]"));
  application->close();
  tap.signal(SIGTERM);
  EXPECT_EQ(tap.wait(std::chrono::seconds(20)), 0);
}

}  // namespace
}  // namespace tether::cli::testing
