// `tether shell` used the way a person uses it: on a terminal (a new pty is its controlling terminal, stdin,
// stdout and stderr, in the default canonical echoing mode), typing lines and reading the screen.
#include <gtest/gtest.h>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "fake_port.hpp"
#include "tether/testing/child_process.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

TEST(TetherShell, RomiCommandsAnswersAndLogLines) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  Terminal terminal({"shell", "--virtual", "romi-test"});
  ASSERT_TRUE(terminal.expect("connected to virtual romi-test.elf")) << terminal.screen();
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("e\n");
  EXPECT_TRUE(terminal.expect("[0,1,2]")) << terminal.screen();
  terminal.type("s[2,3]\n");
  EXPECT_TRUE(terminal.expect("[0,5]")) << terminal.screen();
  // `g n` logs n lines before it answers.
  terminal.type("g[2]\n");
  EXPECT_TRUE(terminal.expect("log: log 1")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("log: log 2")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("[0]")) << terminal.screen();
  // Errors: the device's (unknown opcode) and the host's (rejected before sending).
  terminal.type("z\n");
  EXPECT_TRUE(terminal.expect("[-16]  error -16: unknown opcode")) << terminal.screen();
  terminal.type("a[40000]\n");
  EXPECT_TRUE(terminal.expect("error -10: value out of range")) << terminal.screen();
  terminal.type(":stats\n");
  EXPECT_TRUE(terminal.expect("frames_ok")) << terminal.screen();
  terminal.type(":nonsense\n");
  EXPECT_TRUE(terminal.expect("unknown shell command :nonsense")) << terminal.screen();
  terminal.type(":help\n");
  EXPECT_TRUE(terminal.expect("Shell commands: :help, :stats")) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

TEST(TetherShell, LogLinesAppearWhileIdle) {
  FakePort device;
  Terminal terminal({"shell", "--port", device.path()});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  // Nobody types; the device speaks.
  device.send("#!battery low: 11.1 V:xxxx\r\n");
  EXPECT_TRUE(terminal.expect("log: battery low: 11.1 V")) << terminal.screen();
  // The prompt is drawn again after the asynchronous line.
  EXPECT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("\x04");  // Ctrl-D: end of input
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// Regression: the shell had no line editing (Up sent `^[[A` as a command). On a terminal it edits with
// libedit: history on Up, cursor movement.
TEST(TetherShell, LineEditingAndHistory) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  Terminal terminal({"shell", "--virtual", "romi-test"});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("s[2,3]\n");
  ASSERT_TRUE(terminal.expect("[0,5]")) << terminal.screen();
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("\x1b[A");  // Up: the previous line again
  EXPECT_TRUE(terminal.expect("s[2,3]")) << terminal.screen();
  terminal.type("\n");
  EXPECT_TRUE(terminal.expect("[0,5]")) << terminal.screen();
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  // Editing inside the line: the opcode typed last, at the start (Ctrl-A, then Right past it, ...).
  terminal.type("[4,5]\x01s\n");
  EXPECT_TRUE(terminal.expect("[0,9]")) << terminal.screen();
  EXPECT_EQ(terminal.screen().find("^["), std::string::npos) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// Regression: a line arriving while the user was typing wiped the typed text from the screen. It is printed
// above, and the prompt with the text typed so far is drawn again; the line still works.
TEST(TetherShell, AsynchronousLineRedrawsThePromptAndTheTypedText) {
  FakePort device;
  Terminal terminal({"shell", "--port", device.path()});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("t[\"half");
  ASSERT_TRUE(terminal.expect("t[\"half")) << terminal.screen();  // echoed
  device.send("#!battery low: 11.1 V:xxxx\r\n");
  EXPECT_TRUE(terminal.expect("log: battery low: 11.1 V")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("romi> t[\"half")) << terminal.screen();
  terminal.type("\x15:quit\n");  // Ctrl-U: the line goes; :quit
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// Ctrl-C while a line is being edited ends the shell cleanly (libedit does not take the signal over).
TEST(TetherShell, CtrlCWhileEditingEndsTheShell) {
  FakePort device;
  Terminal terminal({"shell", "--port", device.path()});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("t[\"half");
  ASSERT_TRUE(terminal.expect("t[\"half")) << terminal.screen();
  terminal.type("\x03");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

TEST(TetherShell, ProxyMessagesAndDeviceEvents) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  Terminal terminal({"shell", "--virtual", "proxy"});
  ASSERT_TRUE(terminal.expect("proxy> ")) << terminal.screen();
  terminal.type("servo-init pin=9 safe-position=90\n");
  // The device reports the pin's state before it acks.
  EXPECT_TRUE(terminal.expect("servo 9 = 90")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("servo-init acked (message id ")) << terminal.screen();
  terminal.type("servo-control pin=9 position=135\n");
  EXPECT_TRUE(terminal.expect("servo 9 = 135")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("servo-control acked")) << terminal.screen();
  terminal.type("digital-control pin=4 state=high\n");
  EXPECT_TRUE(terminal.expect("device error: pin 4 not initialised")) << terminal.screen();
  terminal.type("servo-control pin=9\n");
  EXPECT_TRUE(terminal.expect("error: servo-control: missing position=N")) << terminal.screen();
  terminal.type(":stats\n");
  EXPECT_TRUE(terminal.expect("messages_sent")) << terminal.screen();
  terminal.type("\x04");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// Regression: a lone virtual elcano-node used to capture nothing, so every message came back undelivered.
// Now the board captures drive messages and answers each with a sensor report, which the host captures.
TEST(TetherShell, ElcanoMessagesGoRoundTheRing) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  Terminal terminal({"shell", "--virtual", "elcano-node"});
  ASSERT_TRUE(terminal.expect("the virtual board captures drive messages")) << terminal.screen();
  ASSERT_TRUE(terminal.expect("elcano> ")) << terminal.screen();
  terminal.type("D{s 50}{a 25}\n");
  // The answer can come back round the ring before the send's completion prints "sent": the two lines are
  // checked in either order.
  EXPECT_TRUE(terminal.expect("captured S{s 50}{a 25}{b 0}{p 0,0}")) << terminal.screen();
  EXPECT_TRUE(::tether::testing::eventually(
      [&] { return terminal.screen().find("sent D{s 50}{a 25}") != std::string::npos; }, std::chrono::seconds(20)))
      << terminal.screen();
  // Nobody captures a goal: it comes back to the host.
  terminal.type("G{n 1}{p 0,0}{b 90}\n");
  EXPECT_TRUE(terminal.expect("undeliverable G{n 1}{b 90}{p 0,0}")) << terminal.screen();
  terminal.type("D{s 50}\n");
  EXPECT_TRUE(terminal.expect("error: not an Elcano message (inval_comb)")) << terminal.screen();
  terminal.type(":capture drive\n");
  EXPECT_TRUE(terminal.expect("capturing drive")) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// Regression: with piped input the elcano shell exited at the end of the input, before the answer to
// what it had sent came back round the ring.
TEST(TetherShell, PipedElcanoShellWaitsForTheAnswers) {
  TETHER_REQUIRE_FIRMWARE("elcano-node");
  ::tether::testing::ChildProcess shell(
      {"sh", "-c", "printf 'D{s 50}{a 25}\\nD{s -20}{a 5}\\n' | exec \"$0\" shell --virtual elcano-node",
       TETHER_BINARY},
      /*capture_stdout=*/true);
  std::string out;
  while (const auto line = shell.read_line(std::chrono::seconds(60))) out += *line + "\n";
  EXPECT_EQ(shell.wait(std::chrono::seconds(20)), 0);
  EXPECT_NE(out.find("captured S{s 50}{a 25}{b 0}{p 0,0}"), std::string::npos) << out;
  EXPECT_NE(out.find("captured S{s -20}{a 5}{b 0}{p 0,0}"), std::string::npos) << out;
}

// Regression: an elcano shell whose link failed while it waited for the answers after the end of its input
// exited 0 (the romi and proxy shells exit 2 then).
TEST(TetherShell, ElcanoLinkFailureAfterTheInputEndsWithTwo) {
  FakePort port;  // the ring: reads what the host sends, then goes away
  ::tether::testing::ChildProcess shell(
      {"sh", "-c", "printf 'D{s 50}{a 25}\\n' | exec \"$0\" shell --port \"$1\" --codec elcano --no-reconnect",
       TETHER_BINARY,
       port.path()},
      /*capture_stdout=*/true);
  const std::string sent = port.read_until('\n');
  EXPECT_NE(sent.find("D{s 50}{a 25}"), std::string::npos) << sent;
  port.pty->close();  // unplugged while the shell waits for the answer
  std::string out;
  while (const auto line = shell.read_line(std::chrono::seconds(60))) out += *line + "\n";
  EXPECT_EQ(shell.wait(std::chrono::seconds(20)), 2) << out;
}

// A ring that stopped reading (the pty never drained) and a long input: each send ends at its send
// timeout, and a stop signal ends the shell without sending the lines still read ahead.
TEST(TetherShell, ElcanoShellToADeviceThatStoppedReadingEndsOnASignal) {
  FakePort port;  // never read by the test: the pty fills
  const std::string input = ::testing::TempDir() + "/tether-shell-drive-lines";
  {
    std::ofstream lines(input);
    for (int i = 0; i < 3000; ++i) lines << "D{s " << i % 100 << "}{a 25}\n";
  }
  ::tether::testing::ChildProcess shell({"sh", "-c", "exec \"$0\" shell --port \"$1\" --codec elcano < \"$2\"",
                                         TETHER_BINARY, port.path(), input},
                                        /*capture_stdout=*/true);
  const auto signal_at = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < signal_at) (void)shell.read_line(std::chrono::milliseconds(100));
  ASSERT_TRUE(shell.wait_until_catching(SIGTERM, std::chrono::seconds(60)));  // not the default action
  shell.signal(SIGTERM);
  while (shell.read_line(std::chrono::seconds(30))) {
  }
  const std::optional<int> status = shell.wait(std::chrono::seconds(20));
  ASSERT_TRUE(status.has_value()) << "still running 20 s after SIGTERM";
  EXPECT_EQ(*status, 0);
  std::filesystem::remove(input);
}

// Ctrl-C while the device opens (a proxy device that never answers its handshake) ends the shell with 0,
// as its help says for SIGINT, not with the signal's status.
TEST(TetherShell, CtrlCWhileTheDeviceOpensExitsZero) {
  FakePort port;  // never answers
  const std::string config = patient_proxy_config(port.path(), "tether-shell-patient.json");
  Terminal terminal({"shell", "--config", config, "--device", "silent"});
  ASSERT_TRUE(terminal.expect("waiting for the proxy session")) << terminal.screen();
  terminal.type("\x03");
  EXPECT_EQ(terminal.wait_exit(std::chrono::seconds(60)), 0) << terminal.screen();  // the opening ended at once
}

TEST(TetherShell, LinkFailureEndsTheShellWithTwo) {
  TETHER_REQUIRE_FIRMWARE("proxy");
  auto board = std::make_unique<SimBoard>("proxy");
  Terminal terminal({"shell", "--port", board->pty(), "--codec", "proxy", "--no-reconnect"});
  ASSERT_TRUE(terminal.expect("proxy> ")) << terminal.screen();
  board.reset();  // `tether sim` ends: the pty goes away
  EXPECT_TRUE(terminal.expect("link failed")) << terminal.screen();
  EXPECT_EQ(terminal.wait_exit(), 2) << terminal.screen();
}

// Regression: a romi shell waiting for input used to notice a dead link only at the next command.
TEST(TetherShell, IdleRomiShellHearsOfTheLinkFailure) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  auto board = std::make_unique<SimBoard>("romi-test");
  Terminal terminal({"shell", "--port", board->pty(), "--no-reconnect"});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  board.reset();  // `tether sim` ends: the pty goes away while the shell waits for input
  EXPECT_TRUE(terminal.expect("link failed")) << terminal.screen();
  EXPECT_EQ(terminal.wait_exit(), 2) << terminal.screen();
}

// By default the shell outlives its port: `tether sim` ends (its pty and the --link name go away), the shell
// says so, its calls fail `disconnected`, and when another `tether sim` serves a new pty behind the same name
// the shell says the link is up and the next call is answered.
TEST(TetherShell, RidesOutAnOutageOfItsPort) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string link = ::testing::TempDir() + "/tether-shell-reconnect-" + std::to_string(::getpid());
  const std::vector<std::string> sim = {firmware("romi-test").string(), "--link", link};
  auto board = std::make_unique<SimBoard>(sim);
  Terminal terminal({"shell", "--port", link});
  ASSERT_TRUE(terminal.expect("romi> ")) << terminal.screen();
  terminal.type("e\n");
  ASSERT_TRUE(terminal.expect("[0,1,2]")) << terminal.screen();
  board.reset();  // unplugged
  ASSERT_TRUE(terminal.expect("link down: " + link + ": ")) << terminal.screen();
  terminal.type("e\n");
  EXPECT_TRUE(terminal.expect("disconnected")) << terminal.screen();
  board = std::make_unique<SimBoard>(sim);  // back, maybe under another pts number
  ASSERT_TRUE(terminal.expect("link up after ")) << terminal.screen();
  terminal.type("e\n");
  EXPECT_TRUE(terminal.expect("[0,1,2]")) << terminal.screen();
  terminal.type(":quit\n");
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

}  // namespace
}  // namespace tether::cli::testing
