#include "tether/transports/tcp_stream.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>

namespace tether::transports {

TcpStream::TcpStream(executor_type executor, std::string host, unsigned short port)
    : AsioObjectStream(std::move(executor)), host_(std::move(host)), port_(port) {}

std::shared_ptr<TcpStream> TcpStream::connect(executor_type executor, const std::string& host, unsigned short port,
                                              std::chrono::milliseconds timeout, error_code& error) {
  // Resolve and connect on a private io_context so a deadline applies without needing the caller's
  // executor to run; the connected socket then moves to the stream's strand.
  asio::io_context private_io;
  asio::ip::tcp::resolver resolver(private_io);
  asio::ip::tcp::socket socket(private_io);
  asio::steady_timer timer(private_io, timeout);
  bool timed_out = false;
  error = asio::error::would_block;
  resolver.async_resolve(host, std::to_string(port), [&](error_code resolve_error, auto endpoints) {
    if (resolve_error) {
      error = resolve_error;
      timer.cancel();
      return;
    }
    asio::async_connect(socket, endpoints, [&](error_code connect_error, const auto&) {
      error = connect_error;
      timer.cancel();
    });
  });
  timer.async_wait([&](error_code timer_error) {
    if (timer_error) return;
    timed_out = true;
    resolver.cancel();
    error_code ignored;
    socket.close(ignored);
  });
  private_io.run();
  if (timed_out) error = make_error_code(TransportError::timed_out);
  if (error) return nullptr;
  auto stream = std::make_shared<TcpStream>(std::move(executor), host, port);
  const auto protocol = socket.local_endpoint().protocol();
  const int fd = socket.release(error);
  if (!error) stream->object_.assign(protocol, fd, error);
  if (!error) stream->object_.set_option(asio::ip::tcp::no_delay(true), error);
  if (error) return nullptr;
  return stream;
}

std::shared_ptr<TcpStream> TcpStream::connect(executor_type executor, const std::string& host, unsigned short port,
                                              std::chrono::milliseconds timeout) {
  error_code error;
  auto stream = connect(std::move(executor), host, port, timeout, error);
  if (error) throw boost::system::system_error(error, "connect tcp " + host + ":" + std::to_string(port));
  return stream;
}

}  // namespace tether::transports
