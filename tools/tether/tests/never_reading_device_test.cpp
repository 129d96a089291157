// Every subcommand that talks to a device, against a device that floods the line and never reads what the
// host writes (the pty fills up and the host's writes block): the command must end on its own (budgets,
// --duration) or on SIGINT/SIGTERM, never hang. The signal is sent once the command has stopped writing
// (the pty's unread bytes no longer grow: it is blocked, or idle), so the test does not depend on speed;
// the bound on the exit is a hang limit, not a timing assertion.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <pty.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tether/testing/child_process.hpp"
#include "tether_process.hpp"

namespace {

using namespace std::chrono_literals;

// A pty whose master side writes `flood` over and over and never reads.
class FloodingDevice {
 public:
  explicit FloodingDevice(std::string flood) : flood_(std::move(flood)) {
    char name[256] = {};
    if (::openpty(&master_, &slave_, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty failed");
    path_ = name;
    termios settings{};
    ::tcgetattr(slave_, &settings);
    ::cfmakeraw(&settings);  // no echo of the flood back into what the "device" receives
    ::tcsetattr(slave_, TCSANOW, &settings);
    ::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK);
    writer_ = std::thread([this] {
      while (!stop_) {
        if (::write(master_, flood_.data(), flood_.size()) < 0) std::this_thread::sleep_for(1ms);
      }
    });
  }
  ~FloodingDevice() {
    stop_ = true;
    writer_.join();
    ::close(slave_);
    ::close(master_);
  }
  const std::string& path() const { return path_; }
  // Bytes the host wrote that the device has not read (it never does).
  int unread() const {
    int count = 0;
    ::ioctl(master_, FIONREAD, &count);
    return count;
  }

 private:
  std::string flood_;
  int master_ = -1;
  int slave_ = -1;  // kept open: the pty lives across the command's open and close
  std::string path_;
  std::atomic<bool> stop_{false};
  std::thread writer_;
};

struct Case {
  std::string name;
  std::string flood;
  std::vector<std::string> arguments;  // "PORT" is replaced with the pty's path
  bool signal = true;                  // false: it must end by itself (--duration, budgets)
};

std::ostream& operator<<(std::ostream& out, const Case& c) { return out << c.name; }

class NeverReadingDevice : public ::testing::TestWithParam<Case> {};

TEST_P(NeverReadingDevice, EndsOnItsOwnOrOnStopSignal) {
  const Case& c = GetParam();
  FloodingDevice device(c.flood);
  // "CONFIG": a rover configuration whose one device, an Elcano ring, is the pty.
  const std::string config = ::testing::TempDir() + "never-reading-" + c.name + ".json";
  std::ofstream(config) << R"({"devices": [{"name": "ring", "codec": "elcano", "transport": {"serial": {"path": ")"
                        << device.path() << R"("}}}]})";
  std::vector<std::string> argv = {TETHER_BINARY};
  for (const std::string& argument : c.arguments) {
    argv.push_back(argument == "PORT" ? device.path() : argument == "CONFIG" ? config : argument);
  }
  tether::testing::ChildProcess child(argv);
  const auto started = std::chrono::steady_clock::now();
  if (c.signal) {
    // Wait until the command stopped writing: the unread bytes stay the same for 500 ms (hang limit 30 s).
    int last = -1;
    auto stable_since = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - started < 30s) {
      const int now_unread = device.unread();
      if (now_unread != last) {
        last = now_unread;
        stable_since = std::chrono::steady_clock::now();
      } else if (std::chrono::steady_clock::now() - stable_since > 500ms) {
        break;
      }
      std::this_thread::sleep_for(20ms);
    }
    child.signal(SIGINT);
  }
  const auto signalled = std::chrono::steady_clock::now();
  const auto status = child.wait(30s);  // hang limit
  ASSERT_TRUE(status.has_value()) << "tether " << c.name << " did not end (unread bytes: " << device.unread() << ")";
  const auto ms = [](auto d) { return std::chrono::duration_cast<std::chrono::milliseconds>(d).count(); };
  std::printf("tether %s: ended %lld ms after %s, exit status %d\n", c.name.c_str(),
              static_cast<long long>(ms(std::chrono::steady_clock::now() - signalled)),
              c.signal ? "SIGINT" : "the start", *status);
  // Commands without a stop handler (call, send) end by SIGINT's default action; the others exit.
  EXPECT_TRUE(*status >= 0 || *status == -SIGINT) << "ended by signal " << -*status;
}

const std::string kElcano = "D{s 1}{a 2}\n";

INSTANTIATE_TEST_SUITE_P(
    Subcommands, NeverReadingDevice,
    ::testing::Values(
        Case{"monitor_elcano_duration", kElcano, {"monitor", "--codec", "elcano", "--port", "PORT", "--duration", "3"}, false},
        Case{"monitor_elcano", kElcano, {"monitor", "--codec", "elcano", "--port", "PORT"}},
        Case{"monitor_elcano_tap", kElcano, {"monitor", "--codec", "elcano", "--port", "PORT", "--tap"}},
        Case{"monitor_romi", kElcano, {"monitor", "--port", "PORT"}},
        Case{"monitor_proxy_keepalive", kElcano, {"monitor", "--codec", "proxy", "--port", "PORT", "--keepalive"}},
        Case{"call", kElcano, {"call", "--port", "PORT", "e"}, false},
        Case{"call_signalled", kElcano, {"call", "--port", "PORT", "--timeout", "20000", "e"}},
        Case{"send", kElcano, {"send", "--port", "PORT", "servo-init", "pin=9", "safe-position=90"}},
        Case{"send_compat", kElcano, {"send", "--port", "PORT", "--codec", "proxy-compat", "servo-init", "pin=9", "safe-position=90"}},
        Case{"shell_elcano", kElcano, {"shell", "--codec", "elcano", "--port", "PORT"}, false},
        Case{"stats_romi", kElcano, {"stats", "--port", "PORT", "--duration", "60"}},
        Case{"stats_elcano", kElcano, {"stats", "--codec", "elcano", "--port", "PORT", "--duration", "60"}},
        Case{"monitor_config", kElcano, {"monitor", "--config", "CONFIG", "--device", "ring"}},
        Case{"demo_config", kElcano, {"demo", "--config", "CONFIG", "--iterations", "100000"}},
        Case{"flash", kElcano, {"flash", "--port", "PORT", "romi-test"}}),
    [](const ::testing::TestParamInfo<Case>& param) { return param.param.name; });

}  // namespace
