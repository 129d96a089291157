// `tether monitor`: a device scripted by the test on a pty says exactly what is checked (good frames, a
// log line, damaged frames, garbage), and a virtual proxy board announces its boot.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <signal.h>

#include <string>
#include <vector>

#include "fake_port.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/transports/serial_port_stream.hpp"
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

std::string proxy_frame(const proxy::ArduinoOut& message) {
  const std::string payload = message.SerializeAsString();
  std::uint8_t frame[proxy::max_frame_size(64)];
  const Result<std::size_t> written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                          proxy::Integrity::crc16, false, MutableByteView(frame));
  EXPECT_TRUE(written.ok());
  return std::string(reinterpret_cast<const char*>(frame), written.value());
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

TEST(TetherMonitor, DurationEndsAQuietMonitor) {
  FakePort device;
  const Outcome run = run_tether({"monitor", "--port", device.path(), "--duration", "0.2"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "");
}

TEST(TetherMonitor, LinkFailureExitsTwo) {
  auto device = std::make_unique<FakePort>();
  const std::string path = device->path();
  ::tether::testing::ChildProcess monitor({TETHER_BINARY, "monitor", "--port", path, "--json"}, true);
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
