// `tether send` against the proxy firmware on virtual Unos: through the pty of `tether sim` (--port),
// started by the command itself (--virtual), and from a rover configuration (--config).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "fake_port.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

using nlohmann::json;

// One JSON object per output line.
std::vector<json> json_lines(const Outcome& run) {
  std::vector<json> results;
  for (const std::string& line : run.lines()) results.push_back(json::parse(line));
  return results;
}

TEST(TetherSend, MessagesAreAckedThroughTheSimPty) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  SimBoard board("proxy");
  const Outcome run = run_tether({"send", "--port", board.pty(), "servo-init", "pin=9", "safe-position=90",
                                  "servo-control", "pin=9", "position=120"});
  EXPECT_EQ(run.status, 0) << run.err;
  const auto lines = run.lines();
  ASSERT_EQ(lines.size(), 2u) << run.out;
  EXPECT_TRUE(matches(lines[0], "servo-init: acked, message id #, # attempt*; pin 9 = 90")) << lines[0];
  EXPECT_TRUE(matches(lines[1], "servo-control: acked, message id #, # attempt*; pin 9 = 120")) << lines[1];
}

TEST(TetherSend, JsonPrintsOneObjectPerMessage) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const Outcome run = run_tether({"send", "--virtual", "proxy", "--json", "digital-init", "pin=13", "safeState=false",
                                  "digital-control", "pin=13", "state=on"});
  EXPECT_EQ(run.status, 0) << run.err;
  const auto lines = run.lines();
  ASSERT_EQ(lines.size(), 2u) << run.out;
  const json init = json::parse(lines[0]);
  const json control = json::parse(lines[1]);
  EXPECT_EQ(init["message"], "digital-init");
  EXPECT_EQ(control["message"], "digital-control");
  for (const json* result : {&init, &control}) {
    EXPECT_EQ((*result)["acked"], true);
    EXPECT_EQ((*result)["written"], true);
    EXPECT_TRUE((*result)["message_id"].is_number_unsigned());
    EXPECT_GE((*result)["attempts"].get<int>(), 1);
    EXPECT_TRUE((*result)["error"].is_null());
    EXPECT_EQ((*result)["device_errors"], json::array());
  }
  EXPECT_NE(control["message_id"], init["message_id"]);
  EXPECT_EQ(control["pin_state"], json::parse(R"({"pin":13,"value":1,"failsafe":false})"));
}

TEST(TetherSend, DeviceErrorExitsOne) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  // A fresh session: pin 5 was never initialised (and a servo can only be on D9/D10).
  const Outcome run = run_tether({"send", "--virtual", "proxy", "servo-control", "pin=5", "position=10"});
  EXPECT_EQ(run.status, 1) << run.err;
  EXPECT_NE(run.out.find("servo-control: refused"), std::string::npos) << run.out;  // acked as refused
  EXPECT_NE(run.out.find("device error: pin 5 not initialised"), std::string::npos) << run.out;
}

TEST(TetherSend, ResetStartsANewSession) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const Outcome run = run_tether({"send", "--virtual", "proxy", "--json", "reset"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json result = json::parse(run.out);
  EXPECT_EQ(result["message"], "reset");
  EXPECT_EQ(result["acked"], true);
  EXPECT_TRUE(result["session_id"].is_number_unsigned());
}

TEST(TetherSend, CompatMessagesAreWrittenAndTheDeviceAnswerIsShown) {
  TETHER_REQUIRE_FIRMWARE("proxy-compat");
  // --settle only bounds the wait: the device's EventMessage ends it.
  const Outcome run = run_tether(
      {"send", "--virtual", "proxy-compat", "--settle", "20000", "--json", "servo-init", "pin=9", "safe-position=90"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json result = json::parse(run.out);
  EXPECT_EQ(result["acked"], false);
  EXPECT_EQ(result["written"], true);
  // The device's answer; its boot announcement (RESET 0) may come along, depending on when the board booted.
  const auto& events = result["device_events"];
  EXPECT_NE(std::find(events.begin(), events.end(), "SERVO_INIT 9"), events.end()) << events;
}

// --settle is how long a compat send waits for the device's answer: a device that never answers is
// waited for that long, and the line says so.
TEST(TetherSend, SettleBoundsTheWaitForACompatAnswer) {
  FakePort port;  // a device that never answers
  const auto start = std::chrono::steady_clock::now();
  const Outcome run = run_tether({"send", "--port", port.path(), "--codec", "proxy-compat", "--settle", "1500",
                                  "servo-init", "pin=9", "safe-position=90"});
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(run.status, 0) << run.err;  // compat: written is done
  EXPECT_NE(run.out.find("no answer from the device within 1500 ms"), std::string::npos) << run.out;
  EXPECT_GE(waited, std::chrono::milliseconds(1500));
}

// A proxy board whose answers reach the host `delay` late: the host's port is a FakePort, and two threads
// carry the bytes between it and the board's pty (host -> board at once, board -> host after `delay`).
class SlowAnsweringBoard {
 public:
  explicit SlowAnsweringBoard(std::chrono::milliseconds delay) : board_("proxy"), delay_(delay) {
    board_fd_ = ::open(board_.pty().c_str(), O_RDWR | O_NOCTTY);
    termios mode{};
    ::tcgetattr(board_fd_, &mode);
    ::cfmakeraw(&mode);
    ::tcsetattr(board_fd_, TCSANOW, &mode);
    to_board_ = std::thread([this] {
      char buffer[256];
      while (!stop_) {
        boost::system::error_code error;
        const std::size_t size = host_.pty->read_some(boost::asio::buffer(buffer), std::chrono::milliseconds(20), error);
        if (size > 0) (void)!::write(board_fd_, buffer, size);
      }
    });
    to_host_ = std::thread([this] {
      std::deque<std::pair<std::chrono::steady_clock::time_point, std::string>> line;
      char buffer[256];
      while (!stop_) {
        pollfd ready{board_fd_, POLLIN, 0};
        if (::poll(&ready, 1, 5) > 0) {
          const ssize_t size = ::read(board_fd_, buffer, sizeof buffer);
          if (size > 0) line.emplace_back(std::chrono::steady_clock::now() + delay_, std::string(buffer, static_cast<std::size_t>(size)));
        }
        while (!line.empty() && line.front().first <= std::chrono::steady_clock::now()) {
          host_.send(line.front().second);
          line.pop_front();
        }
      }
    });
  }
  ~SlowAnsweringBoard() {
    stop_ = true;
    to_board_.join();
    to_host_.join();
    ::close(board_fd_);
  }
  SlowAnsweringBoard(const SlowAnsweringBoard&) = delete;
  SlowAnsweringBoard& operator=(const SlowAnsweringBoard&) = delete;

  /// The port the command opens.
  const std::string& path() const { return host_.path(); }

 private:
  SimBoard board_;
  FakePort host_;
  std::chrono::milliseconds delay_;
  int board_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread to_board_;
  std::thread to_host_;
};

// --timeout is the send's budget: acks 1.5 s late succeed within 5000 ms and fail within 1000 ms. (The
// option was validated, then ignored: every send had 1000 ms.)
TEST(TetherSend, TimeoutIsTheSendBudget) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  const SlowAnsweringBoard board(std::chrono::milliseconds(1500));
  Outcome run = run_tether({"send", "--port", board.path(), "--codec", "proxy", "--timeout", "5000", "--json",
                            "servo-init", "pin=9", "safe-position=90"});
  EXPECT_EQ(run.status, 0) << run.out << run.err;
  run = run_tether({"send", "--port", board.path(), "--codec", "proxy", "--timeout", "1000", "--json",
                    "servo-init", "pin=9", "safe-position=90"});
  EXPECT_EQ(run.status, 2) << run.out << run.err;
}

// A servo-init then a servo-control on D3 through a compat device: each lists only its own event. Returns
// the control's result (null when the run did not print two results).
json expect_init_and_control_on_d3(const Outcome& run) {
  EXPECT_EQ(run.status, 0) << run.err;
  const std::vector<json> results = json_lines(run);
  EXPECT_EQ(results.size(), 2u) << run.out;
  if (results.size() != 2) return json();
  EXPECT_EQ(results[0]["device_events"], json::array({"SERVO_INIT 3"})) << results[0];
  EXPECT_EQ(results[1]["device_events"], json::array({"SERVO_CONTROL 3"})) << results[1];
  return results[1];
}

TEST(TetherSend, CompatListsEachEventUnderTheMessageItAnswers) {
  TETHER_REQUIRE_FIRMWARE("proxy-compat");
  // A servo on D3 (any pin, as the deployed firmware); each event under the message it answers.
  const Outcome run = run_tether({"send", "--virtual", "proxy-compat", "--settle", "20000", "--json", "servo-init",
                                  "pin=3", "safe-position=90", "servo-control", "pin=3", "position=120"});
  const json control = expect_init_and_control_on_d3(run);
  for (const auto& event : control.value("other_device_events", json::array())) {
    EXPECT_NE(event, "SERVO_INIT 3") << control;
  }
}

TEST(TetherSend, CompatEventsThatDoNotAnswerTheMessageAreListedApart) {
  // A scripted device: SERVO_INIT 3 answers the init; during the control a stray SERVO_INIT 3 (what an init
  // replayed on the device's RESET got from the old image) comes before SERVO_CONTROL 3. It used to be
  // listed as the control's answer.
  FakePort port;
  const std::string servo_init_3 = {0x07, 0x0a, 0x04, 0x08, 0x01, 0x10, 0x03, 0x00};
  const std::string servo_control_3 = {0x07, 0x0a, 0x04, 0x08, 0x02, 0x10, 0x03, 0x00};
  std::thread device([&] {
    const auto read_frame = [&] {  // the host writes 00 COBS(pb) 00
      std::string got;
      while (std::count(got.begin(), got.end(), '\0') < 2) {
        const std::string more = port.read_until('\0');
        if (more.empty()) return;
        got += more;
      }
    };
    read_frame();
    port.send(servo_init_3);
    read_frame();
    port.send(servo_init_3 + servo_control_3);
  });
  const Outcome run = run_tether({"send", "--port", port.path(), "--codec", "proxy-compat", "--settle", "20000",
                                  "--json", "servo-init", "pin=3", "safe-position=90", "servo-control", "pin=3",
                                  "position=120"});
  device.join();
  const json control = expect_init_and_control_on_d3(run);
  EXPECT_EQ(control["other_device_events"], json::array({"SERVO_INIT 3"})) << control;
}

TEST(TetherSend, ConfiguredInitsComeFirst) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  // The rover's "servos" device inits D9, D10 and D13 when it opens, so a control needs no init here.
  const Outcome run =
      run_tether({"send", "--config", kRover, "--device", "servos", "servo-control", "pin=10", "position=45"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(matches(run.out, "servo-control: acked, message id #, # attempt*; pin 10 = 45\n")) << run.out;
}

}  // namespace
}  // namespace tether::cli::testing
