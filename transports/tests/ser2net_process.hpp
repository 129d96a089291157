/// @file ser2net_process.hpp
/// A real ser2net (Debian package) exposing one serial device on 127.0.0.1, for transport and interop tests.
/// Config, pid file and everything else live in a private temporary directory removed afterwards.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "tether/testing/child_process.hpp"

namespace tether::transports::test_support {

/// ser2net serving `device` (e.g. a pty slave) at 115200 8N1 on a free loopback port.
class Ser2netProcess {
 public:
  explicit Ser2netProcess(const std::string& device, const std::string& line_settings = "115200n81") {
    static int instance = 0;
    dir_ = std::filesystem::temp_directory_path() /
           ("tether-ser2net-" + std::to_string(::getpid()) + "-" + std::to_string(instance++));
    std::filesystem::create_directories(dir_);
    port_ = free_port();
    const auto config = dir_ / "ser2net.yaml";
    std::ofstream(config) << "%YAML 1.1\n---\n"
                          << "connection: &device\n"
                          << "  accepter: tcp,127.0.0.1," << port_ << "\n"
                          << "  enable: on\n"
                          << "  options:\n"
                          << "    kickolduser: true\n"
                          << "  connector: serialdev," << device << "," << line_settings << ",local\n";
    // -n: stay in the foreground (so the test owns the process); -u: no UUCP lock files in /var/lock.
    process_ = std::make_unique<tether::testing::ChildProcess>(std::vector<std::string>{
        "ser2net", "-n", "-u", "-c", config.string(), "-P", (dir_ / "ser2net.pid").string()});
  }
  ~Ser2netProcess() {
    process_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  /// TCP port ser2net accepts on (127.0.0.1).
  unsigned short port() const { return port_; }
  /// True once ser2net accepts connections.
  bool wait_until_listening(std::chrono::milliseconds timeout) {
    return tether::testing::eventually(
        [this] {
          boost::asio::io_context io;
          boost::asio::ip::tcp::socket probe(io);
          boost::system::error_code error;
          probe.connect({boost::asio::ip::make_address("127.0.0.1"), port_}, error);
          return !error;
        },
        timeout);
  }

 private:
  static unsigned short free_port() {
    boost::asio::io_context io;
    boost::asio::ip::tcp::acceptor acceptor(io, {boost::asio::ip::make_address("127.0.0.1"), 0});
    return acceptor.local_endpoint().port();
  }

  std::filesystem::path dir_;
  unsigned short port_ = 0;
  std::unique_ptr<tether::testing::ChildProcess> process_;
};

}  // namespace tether::transports::test_support
