#include "tether/transports/tcp_stream.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/steady_timer.hpp>

namespace tether::transports {

TcpStream::TcpStream(executor_type executor, std::string host, unsigned short port)
    : AsioObjectStream(std::move(executor)), host_(std::move(host)), port_(port) {}

void TcpStream::start_connect(executor_type executor, const std::string& host, unsigned short port,
                              std::chrono::milliseconds timeout, UniqueFunction<ConnectSignature> handler) {
  // Resolver, connect and deadline all run on the new stream's strand; whichever ends first decides.
  struct Attempt {
    std::shared_ptr<TcpStream> stream;
    asio::ip::tcp::resolver resolver;
    asio::steady_timer deadline;
    UniqueFunction<ConnectSignature> handler;
    bool timed_out = false;
    void finish(error_code error) {
      deadline.cancel();
      if (timed_out) error = make_error_code(TransportError::timed_out);
      if (!error) stream->object_.set_option(asio::ip::tcp::no_delay(true), error);
      if (!handler) return;
      auto done = std::move(handler);
      if (error) {
        error_code ignored;
        stream->object_.close(ignored);
        done(error, nullptr);
      } else {
        done(error, stream);
      }
    }
  };
  auto stream = std::make_shared<TcpStream>(std::move(executor), host, port);
  auto attempt = std::make_shared<Attempt>(
      Attempt{stream, asio::ip::tcp::resolver(stream->strand()), asio::steady_timer(stream->strand()), std::move(handler)});
  attempt->deadline.expires_after(timeout);
  attempt->deadline.async_wait([attempt](error_code error) {
    if (error) return;
    attempt->timed_out = true;
    attempt->resolver.cancel();
    error_code ignored;
    attempt->stream->object_.close(ignored);  // aborts a connect in progress
  });
  attempt->resolver.async_resolve(host, std::to_string(port), [attempt](error_code error, auto endpoints) {
    if (error || attempt->timed_out) {
      attempt->finish(error ? error : make_error_code(TransportError::timed_out));
      return;
    }
    asio::async_connect(attempt->stream->object_, endpoints,
                        [attempt](error_code connect_error, const auto&) { attempt->finish(connect_error); });
  });
}

std::shared_ptr<TcpStream> TcpStream::connect(executor_type executor, const std::string& host, unsigned short port,
                                              std::chrono::milliseconds timeout, error_code& error) {
  auto result = async_connect(std::move(executor), host, port, timeout, asio::use_future);
  return get_or_error(result, error);
}

std::shared_ptr<TcpStream> TcpStream::connect(executor_type executor, const std::string& host, unsigned short port,
                                              std::chrono::milliseconds timeout) {
  error_code error;
  auto stream = connect(std::move(executor), host, port, timeout, error);
  if (error) throw boost::system::system_error(error, "connect tcp " + host + ":" + std::to_string(port));
  return stream;
}

}  // namespace tether::transports
