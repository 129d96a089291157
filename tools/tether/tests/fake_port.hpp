// A device played by the test on the master side of a pty; the command under test opens the slave like a
// serial port. Bytes written before the command opens the port wait in the pty (raw mode, nothing is
// flushed without --boot-wait), so a test can script what the "device" says without racing the command.
#pragma once

#include <boost/asio/buffer.hpp>

#include <chrono>
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

}  // namespace tether::cli::testing
