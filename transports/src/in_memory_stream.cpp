#include "tether/transports/in_memory_stream.hpp"

#include <boost/asio/error.hpp>

#include <algorithm>
#include <cstdint>
#include <deque>
#include <mutex>

namespace tether::transports {

// One direction of the pair. The reader's and writer's pending operations wait here; whoever makes
// progress possible completes the other side by posting its handler to that side's strand.
struct InMemoryStream::Channel {
  struct Waiter {
    asio::mutable_buffer read_target;
    asio::const_buffer write_source;
    IoHandler handler;
    asio::strand<asio::any_io_executor> strand;
  };

  explicit Channel(std::size_t bound) : capacity(bound) {}

  std::mutex mutex;
  std::deque<std::uint8_t> bytes;
  std::size_t capacity;
  bool writer_closed = false;
  bool reader_closed = false;
  std::unique_ptr<Waiter> reader;
  std::unique_ptr<Waiter> writer;

  static void complete(std::unique_ptr<Waiter> waiter, error_code error, std::size_t size) {
    auto strand = waiter->strand;
    asio::post(strand, [waiter = std::move(waiter), error, size]() mutable { waiter->handler(error, size); });
  }
  // Moves bytes from the queue into a waiting reader; call with the mutex held.
  std::unique_ptr<Waiter> serve_reader(std::size_t& size) {
    size = std::min(bytes.size(), reader->read_target.size());
    auto* target = static_cast<std::uint8_t*>(reader->read_target.data());
    std::copy_n(bytes.begin(), static_cast<std::ptrdiff_t>(size), target);
    bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
    return std::move(reader);
  }
  // Moves bytes of a waiting writer into the queue; call with the mutex held.
  std::unique_ptr<Waiter> serve_writer(std::size_t& size) {
    size = std::min(capacity - bytes.size(), writer->write_source.size());
    const auto* source = static_cast<const std::uint8_t*>(writer->write_source.data());
    bytes.insert(bytes.end(), source, source + size);
    return std::move(writer);
  }
};

std::pair<std::shared_ptr<InMemoryStream>, std::shared_ptr<InMemoryStream>> InMemoryStream::make_pair(
    executor_type executor, std::size_t capacity) {
  return make_pair(executor, executor, capacity);
}

std::pair<std::shared_ptr<InMemoryStream>, std::shared_ptr<InMemoryStream>> InMemoryStream::make_pair(
    executor_type executor_a, executor_type executor_b, std::size_t capacity) {
  const std::size_t bound = capacity == 0 ? 1 : capacity;
  auto a_to_b = std::make_shared<Channel>(bound);
  auto b_to_a = std::make_shared<Channel>(bound);
  return {std::make_shared<InMemoryStream>(std::move(executor_a), b_to_a, a_to_b, "in-memory end A"),
          std::make_shared<InMemoryStream>(std::move(executor_b), a_to_b, b_to_a, "in-memory end B")};
}

InMemoryStream::InMemoryStream(executor_type executor, std::shared_ptr<Channel> incoming,
                               std::shared_ptr<Channel> outgoing, std::string name)
    : ByteStream(std::move(executor)),
      incoming_(std::move(incoming)),
      outgoing_(std::move(outgoing)),
      name_(std::move(name)) {}

InMemoryStream::~InMemoryStream() {
  // An end that goes away closes its side of both channels, like a process exiting closes its fds. Its
  // own parked read points into its buffer: withdraw it.
  {
    std::lock_guard lock(incoming_->mutex);
    incoming_->reader.reset();
  }
  {
    std::lock_guard lock(outgoing_->mutex);
    outgoing_->writer_closed = true;
    if (outgoing_->reader) Channel::complete(std::move(outgoing_->reader), asio::error::eof, 0);
  }
  std::lock_guard lock(incoming_->mutex);
  incoming_->reader_closed = true;
  if (incoming_->writer) Channel::complete(std::move(incoming_->writer), asio::error::broken_pipe, 0);
}

void InMemoryStream::do_read(asio::mutable_buffer buffer, IoHandler handler) {
  Channel& channel = *incoming_;
  std::unique_lock lock(channel.mutex);
  auto waiter = std::make_unique<Channel::Waiter>(Channel::Waiter{buffer, {}, std::move(handler), strand()});
  if (channel.bytes.empty()) {
    if (channel.writer_closed) {
      lock.unlock();
      Channel::complete(std::move(waiter), asio::error::eof, 0);
      return;
    }
    channel.reader = std::move(waiter);
    return;
  }
  channel.reader = std::move(waiter);
  std::size_t size = 0;
  auto served = channel.serve_reader(size);
  // Space freed: a writer waiting for it can go on.
  std::unique_ptr<Channel::Waiter> writer;
  std::size_t written = 0;
  if (channel.writer) writer = channel.serve_writer(written);
  lock.unlock();
  Channel::complete(std::move(served), error_code(), size);
  if (writer) Channel::complete(std::move(writer), error_code(), written);
}

void InMemoryStream::do_write(asio::const_buffer buffer, IoHandler handler) {
  Channel& channel = *outgoing_;
  std::unique_lock lock(channel.mutex);
  auto waiter = std::make_unique<Channel::Waiter>(Channel::Waiter{{}, buffer, std::move(handler), strand()});
  if (channel.reader_closed) {
    lock.unlock();
    Channel::complete(std::move(waiter), asio::error::broken_pipe, 0);
    return;
  }
  channel.writer = std::move(waiter);
  if (channel.bytes.size() == channel.capacity) return;  // full: wait for the reader
  std::size_t written = 0;
  auto served = channel.serve_writer(written);
  std::unique_ptr<Channel::Waiter> reader;
  std::size_t read = 0;
  if (channel.reader) reader = channel.serve_reader(read);
  lock.unlock();
  Channel::complete(std::move(served), error_code(), written);
  if (reader) Channel::complete(std::move(reader), error_code(), read);
}

void InMemoryStream::do_close(error_code& error) {
  error = error_code();
  std::unique_ptr<Channel::Waiter> own_reader;
  std::unique_ptr<Channel::Waiter> own_writer;
  std::unique_ptr<Channel::Waiter> peer_reader;
  std::unique_ptr<Channel::Waiter> peer_writer;
  {
    std::lock_guard lock(incoming_->mutex);
    incoming_->reader_closed = true;
    own_reader = std::move(incoming_->reader);
    peer_writer = std::move(incoming_->writer);
  }
  {
    std::lock_guard lock(outgoing_->mutex);
    outgoing_->writer_closed = true;
    own_writer = std::move(outgoing_->writer);
    if (outgoing_->bytes.empty()) peer_reader = std::move(outgoing_->reader);
  }
  if (own_reader) Channel::complete(std::move(own_reader), asio::error::operation_aborted, 0);
  if (own_writer) Channel::complete(std::move(own_writer), asio::error::operation_aborted, 0);
  if (peer_reader) Channel::complete(std::move(peer_reader), asio::error::eof, 0);
  if (peer_writer) Channel::complete(std::move(peer_writer), asio::error::broken_pipe, 0);
}

}  // namespace tether::transports
