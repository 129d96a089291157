/// @file in_memory_stream.hpp
/// Two connected in-memory byte streams: what one writes, the other reads. For tests and tools.
///
/// Each direction holds at most `capacity` bytes; a writer whose peer does not read waits (its write
/// completes when space frees up), as on a real link with flow control. Closing one end makes the other
/// read EOF after the bytes already sent, and fail writes with `broken_pipe`.
#pragma once

#include <memory>
#include <string>
#include <utility>

#include "tether/transports/byte_stream.hpp"

namespace tether::transports {

/// One end of an in-memory pair.
class InMemoryStream final : public ByteStream {
 public:
  struct Channel;

  /// Two connected ends; both complete on strands of `executor`.
  static std::pair<std::shared_ptr<InMemoryStream>, std::shared_ptr<InMemoryStream>> make_pair(
      executor_type executor, std::size_t capacity = 4096);
  /// Two connected ends on different executors (end A completes on `executor_a`, end B on `executor_b`),
  /// so each side can run on its own thread: a benchmark's host and its fake devices.
  static std::pair<std::shared_ptr<InMemoryStream>, std::shared_ptr<InMemoryStream>> make_pair(
      executor_type executor_a, executor_type executor_b, std::size_t capacity = 4096);

  std::string description() const override { return name_; }

  /// Constructed by `make_pair` only (public for std::make_shared).
  InMemoryStream(executor_type executor, std::shared_ptr<Channel> incoming, std::shared_ptr<Channel> outgoing,
                 std::string name);
  ~InMemoryStream() override;

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override;
  void do_write(asio::const_buffer buffer, IoHandler handler) override;
  void do_close(error_code& error) override;

 private:
  std::shared_ptr<Channel> incoming_;
  std::shared_ptr<Channel> outgoing_;
  std::string name_;
};

}  // namespace tether::transports
