/// @file tcp_stream.hpp
/// A raw TCP byte stream, to reach a device shared by ser2net (or any TCP-serial bridge) on another
/// machine. Nagle's algorithm is off: protocol frames are small and latency matters more than packing.
#pragma once

#include <boost/asio/ip/tcp.hpp>

#include <chrono>
#include <memory>
#include <string>

#include "tether/transports/asio_object_stream.hpp"

namespace tether::transports {

/// TCP client stream; create with `connect`.
class TcpStream final : public AsioObjectStream<asio::ip::tcp::socket> {
 public:
  /// Resolves `host` and connects to `port` within `timeout`. Blocking; call off the executor's threads.
  /// Errors: resolver and socket errors (host_not_found, connection_refused), `TransportError::timed_out`.
  static std::shared_ptr<TcpStream> connect(executor_type executor, const std::string& host, unsigned short port,
                                            std::chrono::milliseconds timeout, error_code& error);
  /// Throwing variant of `connect`.
  static std::shared_ptr<TcpStream> connect(executor_type executor, const std::string& host, unsigned short port,
                                            std::chrono::milliseconds timeout = std::chrono::seconds(5));

  std::string description() const override { return "tcp " + host_ + ":" + std::to_string(port_); }

  /// Constructed by `connect` (public for std::make_shared).
  TcpStream(executor_type executor, std::string host, unsigned short port);

 private:
  std::string host_;
  unsigned short port_;
};

}  // namespace tether::transports
