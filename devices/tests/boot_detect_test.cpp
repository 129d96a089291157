// Boot detection end to end: a virtual Uno with optiboot that resets into the bootloader whenever its pty
// is opened (an Uno's DTR), opened through a rover configuration as a user writes one. A fixed 2 s wait and
// the codec's detection (Romi: probe after optiboot's quiet second; proxy: its ResetEvent frame) are both
// measured from the open to ready, printed, and compared; the first call right after the detected boot
// succeeds. Only the fixed wait is a wall-clock duration by construction; the detected boot's upper bound
// is generous (a loaded machine runs the simulator slower), and the comparison with the 2 s is the claim.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/proxy/client.hpp"
#include "tether/romi/client.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::devices {
namespace {

using namespace std::chrono_literals;

const std::filesystem::path kFirmware(TETHER_FIRMWARE_DIR);

// An Uno with optiboot and `image`, whose pty resets it into optiboot when a client opens it.
class UnoWithOptiboot {
 public:
  explicit UnoWithOptiboot(const std::string& image) {
    transports::VirtualUnoOptions options;
    options.firmware = kFirmware / (image + ".elf");
    options.bootloader = kFirmware / "optiboot-atmega328.hex";
    options.reset_on_open = true;
    options.pacing = transports::Pacing::real_time;
    std::error_code error;
    std::string message;
    board_ = transports::VirtualUno::create(options, error, &message);
    if (!board_) throw std::runtime_error("virtual Uno: " + message);
    pty_ = board_->open_pty();
    board_->start();
  }
  ~UnoWithOptiboot() { board_->stop(); }
  const std::string& pty() const { return pty_; }
  transports::VirtualUno& board() { return *board_; }

 private:
  std::shared_ptr<transports::VirtualUno> board_;
  std::string pty_;
};

bool have_optiboot() { return std::filesystem::exists(kFirmware / "optiboot-atmega328.hex"); }

RoverConfig serial_device(const std::string& codec, const std::string& pty, const std::string& boot_keys) {
  return parse_config(R"({"devices": [{"name": "board", "codec": ")" + codec + R"(", "transport": {"serial": {"path": ")" +
                      pty + R"(", "reconnect": false)" + boot_keys + "}}}]}");
}

void print(const char* what, const transports::BootReport& report) {
  std::printf("%s: ready after %lld ms (%s, %s, %u probes)\n", what, static_cast<long long>(report.ready_after.count()),
              transports::to_string(report.mode), transports::to_string(report.outcome), report.probes);
}

TEST(DevicesBootDetection, RomiBoardBehindOptibootIsReadySoonerThanTheFixedWaitAndAnswersAtOnce) {
  if (!have_optiboot()) GTEST_SKIP() << "optiboot is not built (arduino-core-avr missing; tools/setup installs it)";
  UnoWithOptiboot uno("romi-test");
  transports::IoThread io;

  transports::BootReport fixed;
  {
    Rover rover = open_rover(serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 2000, "boot": "fixed")"), io.executor());
    fixed = rover.devices()[0].port->boot_report();
    rover.close();
  }
  transports::BootReport detected;
  {
    // The default for a romi device; 10 s only bounds a simulator slowed down by a loaded machine.
    Rover rover = open_rover(serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 10000)"), io.executor());
    detected = rover.devices()[0].port->boot_report();
    const romi::RomiResponse values = rover.client<romi::Client>("board")->call("e");
    EXPECT_EQ(values.code, 0) << values.message;
    EXPECT_EQ(values.values, nlohmann::json::parse("[0,1,2]"));
    rover.close();
  }
  print("fixed", fixed);
  print("detect", detected);
  EXPECT_EQ(fixed.outcome, transports::BootOutcome::waited);
  EXPECT_GE(fixed.ready_after, 2000ms);
  EXPECT_EQ(detected.mode, transports::BootMode::detect);
  EXPECT_EQ(detected.outcome, transports::BootOutcome::probed);
  EXPECT_GE(detected.probes, 1u);
  EXPECT_GE(detected.ready_after, 1000ms) << "the first probe waits for optiboot's quiet second";
  EXPECT_LT(detected.ready_after, fixed.ready_after);
  EXPECT_GE(uno.board().stats().port_open_resets, 2u) << "each open reset the board into optiboot";
}

TEST(DevicesBootDetection, ProxyBoardBehindOptibootIsReadyWhenItsResetEventArrives) {
  if (!have_optiboot()) GTEST_SKIP() << "optiboot is not built (arduino-core-avr missing; tools/setup installs it)";
  UnoWithOptiboot uno("proxy");
  transports::IoThread io;
  Rover rover = open_rover(serial_device("proxy", uno.pty(), R"(, "boot_wait_ms": 10000)"), io.executor());
  const transports::BootReport detected = rover.devices()[0].port->boot_report();
  print("detect", detected);
  EXPECT_EQ(detected.outcome, transports::BootOutcome::announced);
  EXPECT_EQ(detected.probes, 0u);
  EXPECT_GE(detected.ready_after, 1000ms) << "optiboot's second comes first";
  // The announcement was the client's too: its session started from that ResetEvent, and a send is acked.
  const auto servos = rover.client<proxy::Client>("board");
  EXPECT_TRUE(servos->session().established);
  EXPECT_TRUE(servos->digital(13).set(true).acked);
  rover.close();
}

// A board that never says it booted (an image the codec does not know: echo's banner is no Romi answer,
// and it answers no probe): the upper bound ends the wait, the open falls back to the fixed wait's result
// and says so. Never a hang.
TEST(DevicesBootDetection, BoardThatNeverAnnouncesFallsBackAtTheUpperBound) {
  if (!have_optiboot()) GTEST_SKIP() << "optiboot is not built (arduino-core-avr missing; tools/setup installs it)";
  UnoWithOptiboot uno("proxy-compat");  // silent at boot, and a Romi probe is no frame it answers
  transports::IoThread io;
  Rover rover = open_rover(serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 1500, "baud": 57600)"), io.executor());
  const transports::BootReport report = rover.devices()[0].port->boot_report();
  print("never announces", report);
  EXPECT_EQ(report.outcome, transports::BootOutcome::upper_bound);
  EXPECT_GE(report.ready_after, 1500ms);
  EXPECT_LT(report.ready_after, 10s);
  rover.close();
}

}  // namespace
}  // namespace tether::devices
