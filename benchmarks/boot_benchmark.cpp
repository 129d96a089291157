// Time from opening a serial port to the board being ready, per image and boot mode, on a virtual Uno with
// optiboot that resets when its pty is opened (an Uno's DTR): the fixed 2 s wait against detection (the
// image's ResetEvent, or Romi's probe after 1.2 s of quiet). Each open goes through a rover configuration as
// a user writes one; the report is the port's (`SerialPortStream::boot_report()`, host time) and the board's
// simulated time from before the open to after it returned (what a real board takes; it includes a proxy or
// rpc client's handshake). A benchmark, not a test: it prints what it measured.
//
//   tether_boot_benchmark [--runs N]      (default 5)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace {

using namespace std::chrono_literals;
using std::chrono::milliseconds;
namespace transports = tether::transports;
namespace devices = tether::devices;

const std::filesystem::path kFirmware(TETHER_FIRMWARE_DIR);

struct Case {
  const char* image;
  const char* codec;
  const char* options;  // the device's "options" (JSON) or empty
};

struct Run {
  long long host_ms;
  long long board_ms;
  transports::BootOutcome outcome;
  unsigned probes;
};

std::unique_ptr<transports::VirtualUno> optiboot_uno(const std::string& image, std::string& pty) {
  transports::VirtualUnoOptions options;
  options.firmware = kFirmware / (image + ".elf");
  options.bootloader = kFirmware / "optiboot-atmega328.hex";
  options.reset_on_open = true;
  options.pacing = transports::Pacing::real_time;
  std::error_code error;
  std::string message;
  auto board = transports::VirtualUno::create(options, error, &message);
  if (!board) throw std::runtime_error("virtual Uno " + image + ": " + message);
  pty = board->open_pty();
  board->start();
  return board;
}

std::string config_text(const Case& c, const std::string& pty, const char* boot) {
  std::string options = c.options;
  return std::string(R"({"devices": [{"name": "board", "codec": ")") + c.codec +
         R"(", "transport": {"serial": {"path": ")" + pty + R"(", "reconnect": false, "boot_wait_ms": )" +
         (std::string(boot) == "fixed" ? "2000" : "10000") + R"(, "boot": ")" + boot + R"("}})" +
         (options.empty() ? std::string() : R"(, "options": )" + options) + "}]}";
}

void report(const Case& c, const char* boot, std::vector<Run> runs) {
  if (runs.empty()) return;
  const auto stats = [&](auto field) {
    std::vector<long long> values;
    for (const Run& run : runs) values.push_back(field(run));
    std::sort(values.begin(), values.end());
    char text[64];
    std::snprintf(text, sizeof text, "%lld / %lld / %lld", values.front(), values[values.size() / 2], values.back());
    return std::string(text);
  };
  unsigned probes_max = 0;
  bool same_outcome = true;
  for (const Run& run : runs) {
    probes_max = std::max(probes_max, run.probes);
    same_outcome = same_outcome && run.outcome == runs.front().outcome;
  }
  std::printf("| %s | %s | %s%s | %s | %s | %u |\n", c.image, boot, transports::to_string(runs.front().outcome),
              same_outcome ? "" : " (mixed)", stats([](const Run& r) { return r.host_ms; }).c_str(),
              stats([](const Run& r) { return r.board_ms; }).c_str(), probes_max);
}

}  // namespace

int main(int argc, char** argv) {
  int count = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--runs" && i + 1 < argc) {
      count = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: tether_boot_benchmark [--runs N]\n");
      return 2;
    }
  }
  if (count < 1 || count > 100) {
    std::fprintf(stderr, "tether_boot_benchmark: --runs must be 1..100\n");
    return 2;
  }
  if (!std::filesystem::exists(kFirmware / "optiboot-atmega328.hex")) {
    std::fprintf(stderr, "tether_boot_benchmark: optiboot-atmega328.hex is not built (arduino-core-avr missing)\n");
    return 2;
  }
  const std::string rpc_options = R"({"schema": ")" + (kFirmware / "rpc-example.proto").string() + R"("})";
  const std::vector<Case> cases = {
      {"romi-test", "romi", ""},
      {"proxy", "proxy", ""},
      {"rpc-example", "rpc", rpc_options.c_str()},
  };
  double load[1] = {0};
  (void)!getloadavg(load, 1);
  std::printf("Open to ready behind optiboot, %d runs each (min / median / max), load average %.2f at the start\n\n",
              count, load[0]);
  std::printf("| image | boot | outcome | host ms | board ms | probes (max) |\n|---|---|---|---|---|---|\n");
  try {
    transports::IoThread io;
    for (const Case& c : cases) {
      std::string pty;
      auto board = optiboot_uno(c.image, pty);
      while (board->simulated_time() < 200ms) std::this_thread::sleep_for(1ms);  // power-on boot done
      for (const char* boot : {"fixed", "detect"}) {
        std::vector<Run> runs;
        for (int i = 0; i < count; ++i) {
          const auto before = board->simulated_time();
          devices::Rover rover = devices::open_rover(devices::parse_config(config_text(c, pty, boot)), io.executor());
          const auto board_time = std::chrono::duration_cast<milliseconds>(board->simulated_time() - before);
          const transports::BootReport boot_report = rover.devices()[0].port->boot_report();
          rover.close();
          runs.push_back(Run{static_cast<long long>(boot_report.ready_after.count()),
                             static_cast<long long>(board_time.count()), boot_report.outcome, boot_report.probes});
        }
        report(c, boot, runs);
      }
      board->stop();
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "tether_boot_benchmark: %s\n", error.what());
    return 1;
  }
  return 0;
}
