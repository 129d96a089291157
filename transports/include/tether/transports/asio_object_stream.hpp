/// @file asio_object_stream.hpp
/// Adapts an asio I/O object with `async_read_some`/`async_write_some`/`close` (serial_port, tcp::socket,
/// posix::stream_descriptor) to the ByteStream hooks. The object lives on the stream's strand.
#pragma once

#include <boost/asio/bind_executor.hpp>

#include <utility>

#include "tether/transports/byte_stream.hpp"

namespace tether::transports {

/// ByteStream over an asio I/O object of type `Object`.
template <typename Object>
class AsioObjectStream : public ByteStream {
 public:
  /// The underlying asio object (for options the stream does not wrap).
  Object& object() { return object_; }

 protected:
  /// Stream whose object is created on the stream's strand from `args` (after the executor).
  template <typename... Args>
  explicit AsioObjectStream(executor_type executor, Args&&... args)
      : ByteStream(std::move(executor)), object_(strand(), std::forward<Args>(args)...) {}

  void do_read(asio::mutable_buffer buffer, IoHandler handler) override {
    object_.async_read_some(buffer, asio::bind_executor(strand(), std::move(handler)));
  }
  void do_write(asio::const_buffer buffer, IoHandler handler) override {
    object_.async_write_some(buffer, asio::bind_executor(strand(), std::move(handler)));
  }
  void do_close(error_code& error) override {
    if (object_.is_open()) object_.close(error);
  }

  Object object_;  ///< The device.
};

}  // namespace tether::transports
