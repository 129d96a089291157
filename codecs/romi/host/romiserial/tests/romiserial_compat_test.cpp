// RomiSerial's host API on Tether (RomiSerialClient.h, RSerial.h, Console.h): the README's Blink and
// AnalogRead programs, built from examples/cpp-romiserial, run against virtual boards; and what `send`
// puts into the response, in RomiSerial's shapes.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <Console.h>
#include <RSerial.h>
#include <RomiSerialClient.h>

#include "tether/romi/errors.hpp"
#include "tether/testing/child_process.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace {

using namespace std::chrono_literals;
using romiserial::ILog;
using romiserial::RomiSerialClient;
using romiserial::RSerial;
using tether::testing::ChildProcess;
using tether::transports::VirtualUno;
using tether::transports::VirtualUnoOptions;

// A virtual board on a pty, running, its firmware listening.
struct Board {
  explicit Board(const std::string& image) : uno(options(image)) {
    port = uno.open_pty();
    uno.start();
    while (!uno.uart().rx_enabled) std::this_thread::sleep_for(1ms);
  }
  static VirtualUnoOptions options(const std::string& image) {
    VirtualUnoOptions options;
    options.firmware = TETHER_FIRMWARE_DIR "/" + image + ".elf";
    return options;
  }
  VirtualUno uno;
  std::string port;
};

// Keeps every message, for the assertions.
class RecordingLog : public ILog {
 public:
  void error(const char* format, ...) override {
    va_list arguments;
    va_start(arguments, format);
    keep("error", format, arguments);
    va_end(arguments);
  }
  void warn(const char* format, ...) override {
    va_list arguments;
    va_start(arguments, format);
    keep("warn", format, arguments);
    va_end(arguments);
  }
  void debug(const char* format, ...) override {
    va_list arguments;
    va_start(arguments, format);
    keep("debug", format, arguments);
    va_end(arguments);
  }
  std::vector<std::string> lines() {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  void keep(const char* level, const char* format, va_list arguments) __attribute__((format(printf, 3, 0))) {
    char text[512];
    std::vsnprintf(text, sizeof text, format, arguments);
    std::lock_guard lock(mutex_);
    lines_.push_back(std::string(level) + ": " + text);
  }
  std::mutex mutex_;
  std::vector<std::string> lines_;
};

// Runs an example program to its end (they are bounded by their iteration argument).
struct ExampleRun {
  int status = -1000;
  std::vector<std::string> lines;
};
ExampleRun run_example(const std::vector<std::string>& argv) {
  ChildProcess child(argv, true, true);
  ExampleRun run;
  while (auto line = child.read_line(60s)) run.lines.push_back(*line);
  run.status = child.wait(60s).value_or(-1000);
  return run;
}

TEST(RomiSerialCompat, BlinkExampleTurnsTheLedOnAndOff) {
  Board board("romi-blink");
  const auto edges_before = board.uno.pulse_timing(13).edges;
  const ExampleRun run = run_example({BLINK_APP, board.port, "2", "50"});
  EXPECT_EQ(run.status, 0);
  EXPECT_EQ(board.uno.pulse_timing(13).edges - edges_before, 4u);  // on, off, on, off
  EXPECT_FALSE(board.uno.digital_level(13));
}

TEST(RomiSerialCompat, AnalogReadExamplePrintsTheSensorValue) {
  Board board("romi-analogread");
  board.uno.set_analog_input(0, 2.5);  // half of AVcc: 511 or 512
  const ExampleRun run = run_example({ANALOGREAD_APP, board.port, "3", "20"});
  EXPECT_EQ(run.status, 0);
  ASSERT_EQ(run.lines.size(), 3u);
  for (const std::string& line : run.lines) {
    ASSERT_EQ(line.rfind("Sensor value: ", 0), 0u) << line;
    EXPECT_NEAR(std::stoi(line.substr(14)), 512, 1) << line;
  }
}

TEST(RomiSerialCompat, ExamplesRefuseAMissingPortWithAMessage) {
  const ExampleRun run = run_example({BLINK_APP, "/dev/tether-no-such-port", "1", "0"});
  EXPECT_EQ(run.status, 1);
}

TEST(RomiSerialCompat, ResponsesHaveRomiSerialShapes) {
  Board board("romi-blink");
  auto log = std::make_shared<RecordingLog>();
  auto serial = std::make_shared<RSerial>(board.port, 115200, romiserial::kReset, log);
  RomiSerialClient client(serial, serial, log, 0, "blink");
  nlohmann::json response;

  client.send("L[1]", response);
  EXPECT_EQ(response, nlohmann::json::array({0}));
  EXPECT_EQ(client.id(), 1);  // start_id + 1, as in RomiSerial
  EXPECT_TRUE(board.uno.digital_level(13));

  // The device's protocol errors come as [code] and are completed with the code's text.
  client.send("Z", response);
  EXPECT_EQ(response, nlohmann::json::array({-16, RomiSerialClient::get_error_message(-16)}));
  client.send("L", response);
  EXPECT_EQ(response, nlohmann::json::array({-17, RomiSerialClient::get_error_message(-17)}));
  // Commands refused before anything is sent.
  client.send("", response);
  EXPECT_EQ(response, nlohmann::json::array({-24, RomiSerialClient::get_error_message(-24)}));
  client.send(nullptr, response);
  EXPECT_EQ(response[romiserial::kStatusCode], -24);
  client.send("L[40000]", response);
  EXPECT_EQ(response[romiserial::kStatusCode], -10);
  EXPECT_TRUE(response[romiserial::kErrorMessage].is_string());
  client.send("L[0]", response);
  EXPECT_EQ(response, nlohmann::json::array({0}));
  EXPECT_FALSE(board.uno.digital_level(13));
  EXPECT_EQ(std::string(RomiSerialClient::get_error_message(-16)), tether::romi::describe(-16));

  // The port is the client's now.
  char byte = 0;
  EXPECT_FALSE(serial->read(byte));
  EXPECT_FALSE(serial->write('#'));
}

TEST(RomiSerialCompat, DebugLogsRequestsAndAnswers) {
  Board board("romi-blink");
  auto log = std::make_shared<RecordingLog>();
  auto serial = std::make_shared<RSerial>(board.port, 115200, romiserial::kDontReset, log);
  RomiSerialClient client(serial, serial, log, 41, "blink");
  client.set_debug(true);
  nlohmann::json response;
  client.send("L[1]", response);
  EXPECT_EQ(client.id(), 42);
  const auto lines = log->lines();
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back(), "debug: RomiSerialClient<blink>::send: L[1] -> [0]");
}

TEST(RomiSerialCompat, AClientNeedsOneRSerialOfItsOwn) {
  Board board("romi-blink");
  auto log = std::make_shared<RecordingLog>();
  auto serial = std::make_shared<RSerial>(board.port, 115200, romiserial::kDontReset, log);
  RomiSerialClient first(serial, serial, log, 0, "first");
  EXPECT_THROW(RomiSerialClient(serial, serial, log, 0, "second"), std::invalid_argument);
  EXPECT_THROW(RomiSerialClient(serial, nullptr, log, 0, "half"), std::invalid_argument);
  EXPECT_THROW(RomiSerialClient(nullptr, nullptr, log, 0, "none"), std::invalid_argument);
  nlohmann::json response;
  first.send("L[1]", response);  // the first client is unaffected
  EXPECT_EQ(response, nlohmann::json::array({0}));
}

TEST(RomiSerialCompat, AMissingPortThrowsAndIsLogged) {
  auto log = std::make_shared<RecordingLog>();
  try {
    RSerial serial("/dev/tether-no-such-port", 115200, romiserial::kDontReset, log);
    FAIL() << "opened a port that does not exist";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/dev/tether-no-such-port"), std::string::npos) << error.what();
  }
  const auto lines = log->lines();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("error: RSerial: cannot open /dev/tether-no-such-port", 0), 0u) << lines[0];
}

}  // namespace
