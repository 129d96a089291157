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

/// TCP client stream; create with `async_connect` or `connect`.
class TcpStream final : public AsioObjectStream<asio::ip::tcp::socket> {
 public:
  /// Completion signature of `async_connect`.
  using ConnectSignature = void(error_code, std::shared_ptr<TcpStream>);

  /// Resolves `host` and connects to `port` within `timeout`. Completes with the stream, or an error and
  /// null: resolver and socket errors (host_not_found, connection_refused), `TransportError::timed_out`.
  template <typename ConnectToken>
  static auto async_connect(executor_type executor, const std::string& host, unsigned short port,
                            std::chrono::milliseconds timeout, ConnectToken&& token) {
    return asio::async_initiate<ConnectToken, ConnectSignature>(
        [](auto handler, executor_type target, const std::string& name, unsigned short number,
           std::chrono::milliseconds limit) {
          auto bound = bind_to_associated_executor<ConnectSignature>(std::move(handler), target);
          start_connect(std::move(target), name, number, limit, std::move(bound));
        },
        token, std::move(executor), host, port, timeout);
  }

  /// Blocking `async_connect`; needs another thread running the executor (like every blocking call).
  static std::shared_ptr<TcpStream> connect(executor_type executor, const std::string& host, unsigned short port,
                                            std::chrono::milliseconds timeout, error_code& error);
  /// Throwing variant of `connect`.
  static std::shared_ptr<TcpStream> connect(executor_type executor, const std::string& host, unsigned short port,
                                            std::chrono::milliseconds timeout = std::chrono::seconds(5));

  std::string description() const override { return "tcp " + host_ + ":" + std::to_string(port_); }

  /// Constructed by `connect` (public for std::make_shared).
  TcpStream(executor_type executor, std::string host, unsigned short port);

 private:
  static void start_connect(executor_type executor, const std::string& host, unsigned short port,
                            std::chrono::milliseconds timeout, UniqueFunction<ConnectSignature> handler);

  std::string host_;
  unsigned short port_;
};

}  // namespace tether::transports
