// Boot detection end to end: a virtual Uno with optiboot that resets into the bootloader whenever its pty
// is opened (an Uno's DTR), opened through a rover configuration as a user writes one, at the first open
// and at the re-open after an outage (unpluggable_board.hpp). A fixed 2 s wait and the codec's detection
// (Romi: a probe after optiboot's quiet second; proxy, rpc: their ResetEvent frame) are measured from the
// open to ready, printed, and compared; the first call right after the detected boot succeeds.
//
// Comparisons are in the board's simulated time, not wall time: on a loaded machine the simulator runs
// slower than real time, so a wall-clock comparison with the 2 s would measure the machine. The board time
// from just before the open to just after it returned (a bound from above of the open's reset to ready) is
// compared with the fixed wait's 2 s, what it is on a real board. Proxy and rpc are ready when the image
// says so (about 1 s of optiboot plus setup) at any slowdown. A Romi probe goes after 1.2 s of quiet host
// time, at most 1.3 s of board time (the simulator never runs ahead of the host clock, and catches up at
// most 100 ms): answered, it is ready well before 2 s. Only a simulator more than 200 ms behind sends it
// into optiboot, which it ends; the next probe, 1.1 s of host time later, is answered: in that case (2+
// probes) the board's boot was late on the host's clock, nothing a host-timed wait can be compared with,
// and the test says so instead of comparing. Likewise the call after the fixed wait: a simulator that fell
// behind may still be in optiboot when the host's 2 s end, so the call waits for the board's 2 s as well.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/proxy/client.hpp"
#include "tether/romi/client.hpp"
#include "tether/rpc/client.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno.hpp"
#include "proxy_session_log.hpp"
#include "unpluggable_board.hpp"

namespace tether::devices {
namespace {

using namespace std::chrono_literals;
using std::chrono::duration_cast;
using std::chrono::milliseconds;

const std::filesystem::path kFirmware(TETHER_FIRMWARE_DIR);
const std::filesystem::path kOptiboot = kFirmware / "optiboot-atmega328.hex";
constexpr milliseconds kFixedWait = 2000ms;  // SerialOptions::arduino_uno()'s, and the default bound

// An Uno with optiboot and `image`, whose pty resets it into optiboot when a client opens it.
class UnoWithOptiboot {
 public:
  explicit UnoWithOptiboot(const std::string& image) {
    transports::VirtualUnoOptions options;
    options.firmware = kFirmware / (image + ".elf");
    options.bootloader = kOptiboot;
    options.reset_on_open = true;
    options.pacing = transports::Pacing::real_time;
    std::error_code error;
    std::string message;
    board_ = transports::VirtualUno::create(options, error, &message);
    if (!board_) throw std::runtime_error("virtual Uno: " + message);
    pty_ = board_->open_pty();
    board_->start();
    // The power-on boot (straight to the sketch: no DTR yet) runs to the end of setup, so what the image
    // announces then waits in the pty when the test opens it: an old announcement, not the open's boot.
    const auto limit = std::chrono::steady_clock::now() + 20s;
    while (board_->simulated_time() < 200ms && std::chrono::steady_clock::now() < limit) {
      std::this_thread::sleep_for(1ms);
    }
  }
  ~UnoWithOptiboot() { board_->stop(); }
  const std::string& pty() const { return pty_; }
  transports::VirtualUno& board() { return *board_; }

 private:
  std::shared_ptr<transports::VirtualUno> board_;
  std::string pty_;
};

bool have(const std::string& image) {
  return std::filesystem::exists(kOptiboot) && std::filesystem::exists(kFirmware / (image + ".elf"));
}
#define SKIP_WITHOUT(image) \
  if (!have(image)) GTEST_SKIP() << "optiboot or " image " is not built (tools/setup installs arduino-core-avr)"

RoverConfig serial_device(const std::string& codec, const std::string& pty, const std::string& boot_keys,
                          const std::string& options = "") {
  return parse_config(R"({"devices": [{"name": "board", "codec": ")" + codec + R"(", "transport": {"serial": {"path": ")" +
                      pty + R"(", "reconnect": false)" + boot_keys + "}}" +
                      (options.empty() ? std::string() : R"(, "options": )" + options) + "}]}");
}

std::string rpc_options() {
  return R"({"schema": ")" + (kFirmware / "rpc-example.proto").string() + R"("})";
}

// An open measured: how the port says it came up, and the board time it took (from before the open to
// after it returned: never less than the open's reset to ready).
struct Measured {
  transports::BootReport report;
  milliseconds board_time{0};
};

void print(const char* what, const Measured& measured) {
  const transports::BootReport& report = measured.report;
  std::printf("%s: ready after %lld ms host time, %lld ms board time (%s, %s, %u probes)\n", what,
              static_cast<long long>(report.ready_after.count()), static_cast<long long>(measured.board_time.count()),
              transports::to_string(report.mode), transports::to_string(report.outcome), report.probes);
}

// Opens `config`'s one device on `board`, measures it, runs `use` on the rover, closes. A fixed wait is
// host time: a simulator that fell behind on a loaded machine may still be in optiboot when it ends, where a
// real board, whose clock is the host's, never is. With `board_wait`, `use` runs once the board, too, has
// had that long since the open, so the call after a fixed wait tests the port and not the machine's load.
template <typename Use>
Measured open_and_use(transports::VirtualUno& board, const RoverConfig& config, transports::IoThread& io, Use use,
                      milliseconds board_wait = 0ms) {
  Measured measured;
  const auto before = board.simulated_time();
  Rover rover = open_rover(config, io.executor());
  measured.board_time = duration_cast<milliseconds>(board.simulated_time() - before);
  measured.report = rover.devices()[0].port->boot_report();
  if (board.simulated_time() - before < board_wait) {
    std::printf("the simulator fell behind: %lld ms of board time when the wait ended, waiting for %lld\n",
                static_cast<long long>(measured.board_time.count()), static_cast<long long>(board_wait.count()));
    EXPECT_TRUE(testing::wait_until([&] { return board.simulated_time() - before >= board_wait; }))
        << "the board never reached " << board_wait.count() << " ms";
  }
  use(rover);
  rover.close();
  return measured;
}

TEST(DevicesBootDetection, RomiBoardBehindOptibootIsReadySoonerThanTheFixedWaitAndAnswersAtOnce) {
  SKIP_WITHOUT("romi-test");
  UnoWithOptiboot uno("romi-test");
  transports::IoThread io;
  const auto answers = [](Rover& rover) {
    const romi::RomiResponse values = rover.client<romi::Client>("board")->call("e");
    EXPECT_EQ(values.code, 0) << values.message;
    EXPECT_EQ(values.values, nlohmann::json::parse("[0,1,2]"));
  };
  const Measured fixed = open_and_use(
      uno.board(), serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 2000, "boot": "fixed")"), io, answers,
      kFixedWait);
  // The default for a romi device; 10 s only bounds a simulator slowed down by a loaded machine.
  const Measured detected =
      open_and_use(uno.board(), serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 10000)"), io, answers);
  print("fixed", fixed);
  print("detect", detected);
  EXPECT_EQ(fixed.report.outcome, transports::BootOutcome::waited);
  EXPECT_GE(fixed.report.ready_after, kFixedWait);
  EXPECT_EQ(detected.report.mode, transports::BootMode::detect);
  EXPECT_EQ(detected.report.outcome, transports::BootOutcome::probed);
  EXPECT_GE(detected.report.probes, 1u);
  EXPECT_GE(detected.report.ready_after, 1200ms) << "the first probe waits for 1.2 s of quiet";
  if (detected.report.probes == 1) {
    EXPECT_LT(detected.board_time, kFixedWait) << "ready sooner than the fixed wait, in the board's time";
  } else {
    std::printf("the simulator fell behind: the first probe met optiboot, no comparison\n");
  }
  EXPECT_GE(uno.board().stats().port_open_resets, 2u) << "each open reset the board into optiboot";
}

TEST(DevicesBootDetection, ProxyBoardBehindOptibootIsReadyWhenItsResetEventArrivesAndItsSessionStarts) {
  SKIP_WITHOUT("proxy");
  UnoWithOptiboot uno("proxy");
  transports::IoThread io;
  ASSERT_GT(uno.board().stats().tx_bytes, 0u) << "the power-on boot's announcement waits in the pty";
  const Measured detected = open_and_use(
      uno.board(),
      serial_device("proxy", uno.pty(), R"(, "boot_wait_ms": 10000)",
                    R"({"inits": [{"kind": "digital", "pin": 13, "safe_state": false}]})"),
      io, [&](Rover& rover) {
        // The ResetEvent that ended the wait went on to the client: its handshake completes, the init is
        // applied and a send right after is acked.
        const auto client = rover.client<proxy::Client>("board");
        EXPECT_TRUE(client->session().established);
        EXPECT_TRUE(client->digital(13).set(true).acked);
        EXPECT_TRUE(uno.board().pin(13).output && uno.board().pin(13).level);
      });
  print("detect", detected);
  EXPECT_EQ(detected.report.outcome, transports::BootOutcome::announced);
  EXPECT_EQ(detected.report.probes, 0u);
  // Not an announcement queued before the open (the board's clock may catch up at most 100 ms on ours).
  EXPECT_GE(detected.report.ready_after, 900ms) << "the announcement of the boot the open caused";
  EXPECT_GE(detected.board_time, 1000ms) << "optiboot's second comes first";
  EXPECT_LT(detected.board_time, kFixedWait);
  EXPECT_EQ(uno.board().stats().port_open_resets, 1u);
}

TEST(DevicesBootDetection, RpcBoardBehindOptibootIsReadyWhenItsResetEventArrivesAndAnswersACall) {
  SKIP_WITHOUT("rpc-example");
  UnoWithOptiboot uno("rpc-example");
  transports::IoThread io;
  ASSERT_GT(uno.board().stats().tx_bytes, 0u) << "the power-on boot's announcement waits in the pty";
  const Measured detected = open_and_use(
      uno.board(), serial_device("rpc", uno.pty(), R"(, "boot_wait_ms": 10000)", rpc_options()), io,
      [](Rover& rover) {
        const auto client = rover.client<rpc::Client>("board");
        EXPECT_EQ(client->call_json("MoveJoint", R"({"joint": 1, "angleCdeg": 1000})"), R"({"reachedCdeg":1000})");
        EXPECT_TRUE(client->session().established);
      });
  print("detect", detected);
  EXPECT_EQ(detected.report.mode, transports::BootMode::detect);
  EXPECT_EQ(detected.report.outcome, transports::BootOutcome::announced);
  // Not an announcement queued before the open (the board's clock may catch up at most 100 ms on ours).
  EXPECT_GE(detected.report.ready_after, 900ms) << "the announcement of the boot the open caused";
  EXPECT_GE(detected.board_time, 1000ms) << "optiboot's second comes first";
  EXPECT_LT(detected.board_time, kFixedWait);
}

// A board that never says it booted (an image the codec does not know: proxy-compat is silent at boot and
// answers no Romi probe): the upper bound ends the wait, the open falls back to the fixed wait's result
// and says so. Never a hang.
TEST(DevicesBootDetection, BoardThatNeverAnnouncesFallsBackAtTheUpperBound) {
  SKIP_WITHOUT("proxy-compat");
  UnoWithOptiboot uno("proxy-compat");
  transports::IoThread io;
  const Measured report = open_and_use(
      uno.board(), serial_device("romi", uno.pty(), R"(, "boot_wait_ms": 1500, "baud": 57600)"), io, [](Rover&) {});
  print("never announces", report);
  EXPECT_EQ(report.report.outcome, transports::BootOutcome::upper_bound);
  EXPECT_GE(report.report.ready_after, 1500ms);
  EXPECT_LT(report.report.ready_after, 10s);
}

// The same readiness after a re-open: an Uno with optiboot unplugged (its power gone with the cable) and
// plugged back; the re-open resets it into optiboot again (DTR), detection runs again, and the up event
// reports when it was ready. The proxy client then starts its new session by itself.
class DevicesBootDetectionAfterReopen : public testing::ReconnectTest {};

// The port opened again and again while the board talks (the echo image, sent a burst before each open):
// each open resets the board, and the harness never hangs (it used to reset the board under the lock its
// output handler takes: the board's thread waited for the lock, the reset for the board's thread).
TEST_F(DevicesBootDetectionAfterReopen, OpensWhileTheBoardTalksEachResetItAndNothingHangs) {
  SKIP_WITHOUT("echo");
  testing::UnpluggableBoard* const uno = start("echo");
  ASSERT_NE(uno, nullptr);
  uno->unplug();
  const std::string slave = uno->plug();
  uno->reset_on_open();
  const int keeper = ::open(slave.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);  // the host's end, kept open
  ASSERT_GE(keeper, 0);
  ASSERT_TRUE(testing::wait_until([&] { return uno->open_resets() >= 1; }));
  const std::string burst(64, 'x');
  char drained[256];
  for (std::uint64_t open = 2; open <= 201; ++open) {
    // Open while the board is echoing a burst: right after its next byte left.
    const std::uint64_t sent = uno->board().stats().tx_bytes;
    ASSERT_EQ(::write(keeper, burst.data(), burst.size()), static_cast<ssize_t>(burst.size()));
    ASSERT_TRUE(testing::wait_until([&] { return uno->board().stats().tx_bytes > sent; })) << "the board went silent";
    const int fd = ::open(slave.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    ASSERT_GE(fd, 0);
    ::close(fd);
    ASSERT_TRUE(testing::wait_until([&] { return uno->open_resets() >= open; })) << "open " << open;
    while (::read(keeper, drained, sizeof drained) > 0) {
    }
  }
  // Every open the watcher saw reset the board once (inotify may merge two opens into one event).
  EXPECT_GE(uno->open_resets(), 200u);
  EXPECT_EQ(uno->board().stats().injected_external_resets, uno->open_resets());
  ::close(keeper);
}

TEST_F(DevicesBootDetectionAfterReopen, AProxyBoardThatRebootedDuringTheOutageIsDetectedAgainAndTheUpEventSaysWhen) {
  SKIP_WITHOUT("proxy");
  testing::UnpluggableBoard* const uno = start({testing::BoardImage{testing::firmware_image("proxy"), {}, kOptiboot}});
  ASSERT_NE(uno, nullptr);
  uno->reset_on_open();
  const auto before_open = uno->board().simulated_time();
  Rover rover = open_rover(
      parse_config(std::string(R"({"devices": [{"name": "dev", "codec": "proxy", "transport": {"serial": {"port": {"by_id": ")") +
                   testing::kById + R"("}, "boot_wait_ms": 10000}},
                   "options": {"inits": [{"kind": "digital", "pin": 13, "safe_state": true}]}}]})"),
      io.executor());
  const Measured first{rover.devices().at(0).port->boot_report(),
                       duration_cast<milliseconds>(uno->board().simulated_time() - before_open)};
  print("first open", first);
  EXPECT_EQ(first.report.mode, transports::BootMode::detect);
  EXPECT_EQ(first.report.outcome, transports::BootOutcome::announced);
  EXPECT_GE(first.board_time, 1000ms) << "optiboot's second comes first";
  EXPECT_EQ(uno->open_resets(), 1u);

  const auto& port = rover.devices().at(0).port;
  auto events = std::make_shared<testing::EventLog>();
  port->add_link_handler([events](const transports::LinkEvent& event) { events->add(event); });
  const auto client = rover.client<proxy::Client>("dev");
  testing::ProxySessionLog sessions(*client);
  ASSERT_TRUE(client->session().established);

  uno->unplug();
  EXPECT_EQ(events->wait(1).kind, transports::LinkEvent::Kind::down);
  uno->power_cycle();
  EXPECT_FALSE(uno->board().pin(13).output) << "the power cycle forgot the init";
  const auto before_reopen = uno->board().simulated_time();
  uno->plug();
  const transports::LinkEvent up = events->wait(2);
  const Measured reopened{up.boot, duration_cast<milliseconds>(uno->board().simulated_time() - before_reopen)};
  print("re-open", reopened);
  EXPECT_EQ(up.kind, transports::LinkEvent::Kind::up);
  EXPECT_EQ(uno->open_resets(), 2u) << "the re-open reset the board into optiboot";
  EXPECT_EQ(up.boot.mode, transports::BootMode::detect);
  EXPECT_EQ(up.boot.outcome, transports::BootOutcome::announced) << "detected again, not the upper bound";
  EXPECT_GT(up.boot.ready_after, 0ms);
  EXPECT_LT(up.boot.ready_after, 10s);
  EXPECT_GE(reopened.board_time, 1000ms) << "optiboot's second came first again";
  EXPECT_EQ(port->link_counters().last_boot.ready_after, up.boot.ready_after);
  EXPECT_EQ(port->link_counters().last_boot.outcome, transports::BootOutcome::announced);

  // The client starts its new session by itself, the init replayed; a send right after is acked.
  ASSERT_TRUE(sessions.wait_first());
  EXPECT_TRUE(client->session().established);
  EXPECT_TRUE(uno->board().pin(13).output && uno->board().pin(13).level) << "the init replayed";
  boost::system::error_code error;
  EXPECT_TRUE(client->digital(13).set(false, error).acked) << error.message();
  EXPECT_FALSE(error) << error.message();
  rover.close();
}

}  // namespace
}  // namespace tether::devices
