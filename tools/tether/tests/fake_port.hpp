// A device played by the test on the master side of a pty; the command under test opens the slave like a
// serial port. Bytes written before the command opens the port wait in the pty (raw mode, nothing is
// flushed without --boot-wait), so a test can script what the "device" says without racing the command.
#pragma once

#include <gtest/gtest.h>

#include <boost/asio/buffer.hpp>

#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>

#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::cli::testing {

struct FakePort {
  transports::IoThread io;
  std::shared_ptr<transports::PtyStream> pty = transports::PtyStream::open(io.executor());

  ~FakePort() { pty->close(); }

  const std::string& path() const { return pty->slave_path(); }

  /// What the device sends.
  void send(std::string_view bytes) { pty->write(boost::asio::buffer(bytes.data(), bytes.size())); }

  /// What the host sent, until `terminator` (included) or `timeout` (hang protection).
  std::string read_until(char terminator, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::string received;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (received.find(terminator) == std::string::npos && std::chrono::steady_clock::now() < deadline) {
      char buffer[256];
      boost::system::error_code error;
      const std::size_t size = pty->read_some(boost::asio::buffer(buffer), std::chrono::milliseconds(50), error);
      if (error && error != transports::TransportError::timed_out) break;
      received.append(buffer, size);
    }
    return received;
  }
};

/// A configuration file (`name` in the test's temporary folder) of one proxy device "silent" on `port` whose
/// opening waits 10 minutes for the handshake: only a stop can end it within a test's time.
inline std::string patient_proxy_config(const std::string& port, const std::string& name) {
  const std::string file = ::testing::TempDir() + name;
  std::ofstream(file) << R"({"devices": [{"name": "silent", "codec": "proxy", "transport": {"serial": {"path": ")"
                      << port << R"(", "boot_wait_ms": 0}}, "options": {"open_timeout_ms": 600000}}]})";
  return file;
}

}  // namespace tether::cli::testing
