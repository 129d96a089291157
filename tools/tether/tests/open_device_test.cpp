// OpenDevice (device_options.hpp): what a subcommand holds while it runs.
#include <gtest/gtest.h>

#include <pty.h>
#include <unistd.h>

#include <string>

#include "device_options.hpp"
#include "tether/romi/plugin.hpp"
#include "tether/transports/io_thread.hpp"

namespace {

using namespace tether;

// A pty the client opens as its serial port; nobody answers.
class SilentPty {
 public:
  SilentPty() {
    char name[128] = {};
    if (::openpty(&master_, &slave_, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty failed");
    path_ = name;
  }
  ~SilentPty() {
    ::close(master_);
    ::close(slave_);
  }
  const std::string& path() const { return path_; }

 private:
  int master_ = -1;
  int slave_ = -1;
  std::string path_;
};

// `tether stats` closes the device from its Ctrl-C action, then prints the counters: the rover forgets its
// devices when it closes, and reading the client through it then threw std::bad_variant_access.
TEST(OpenDevice, ClientAndCountersStayReadableAfterClose) {
  SilentPty pty;
  cli::DeviceOptions options;
  options.source = cli::DeviceOptions::Source::port;
  options.port = pty.path();
  options.boot_wait_ms = 0;
  std::string error;
  const auto target = cli::resolve_device(options, romi::kCodec, error);
  ASSERT_TRUE(target) << error;
  transports::IoThread io;
  cli::Progress progress("test");
  auto device = cli::open_device(*target, io.executor(), cli::ClientHooks(), progress, error);
  ASSERT_TRUE(device) << error;
  device->close();
  device->close();  // idempotent
  EXPECT_EQ(device->codec(), romi::kCodec);
  ASSERT_NE(device->client_as<romi::Client>(), nullptr);
  EXPECT_FALSE(device->client_as<romi::Client>()->is_open());
  nlohmann::ordered_json counters;
  EXPECT_NO_THROW(counters = device->counters());
  EXPECT_TRUE(counters.contains("link")) << counters.dump();
}

}  // namespace
