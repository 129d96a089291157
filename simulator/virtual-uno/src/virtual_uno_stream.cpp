#include "tether/transports/virtual_uno_stream.hpp"

#include <boost/asio/error.hpp>

#include <algorithm>
#include <thread>

namespace tether::transports {

// Shared between the simulation thread (output handler) and the stream's strand.
struct VirtualUnoStream::Inbox {
  static constexpr std::size_t kCapacity = 64 * 1024;

  std::mutex mutex;
  std::deque<std::uint8_t> bytes;
  std::uint64_t discarded = 0;
  bool closed = false;
  asio::mutable_buffer read_target;
  IoHandler reader;  // a pending read, if any
  asio::strand<asio::any_io_executor> strand;

  explicit Inbox(asio::strand<asio::any_io_executor> reader_strand) : strand(std::move(reader_strand)) {}

  // Hands bytes to the pending reader; call with the mutex held, post the returned completion after.
  std::size_t serve() {
    const std::size_t size = std::min(bytes.size(), read_target.size());
    std::copy_n(bytes.begin(), size, static_cast<std::uint8_t*>(read_target.data()));
    bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
    return size;
  }
  void complete(IoHandler handler, error_code error, std::size_t size) {
    asio::post(strand, [handler = std::move(handler), error, size]() mutable { handler(error, size); });
  }
  // Output handler body: runs on the simulation thread.
  void receive(const std::uint8_t* data, std::size_t size) {
    std::unique_lock lock(mutex);
    if (closed) return;
    bytes.insert(bytes.end(), data, data + size);
    if (bytes.size() > kCapacity) {
      const std::size_t excess = bytes.size() - kCapacity;
      bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(excess));
      discarded += excess;
    }
    if (!reader) return;
    const std::size_t served = serve();
    IoHandler handler = std::move(reader);
    lock.unlock();
    complete(std::move(handler), error_code(), served);
  }
};

std::shared_ptr<VirtualUnoStream> VirtualUnoStream::open(executor_type executor, VirtualUnoOptions options,
                                                         error_code& error) {
  std::error_code create_error;
  std::string message;
  std::unique_ptr<VirtualUno> board = VirtualUno::create(std::move(options), create_error, &message);
  if (!board) {
    error = to_boost_error(create_error);
    return nullptr;
  }
  auto stream = std::make_shared<VirtualUnoStream>(std::move(executor), std::shared_ptr<VirtualUno>(std::move(board)),
                                                   true);
  try {
    stream->board_->start();
  } catch (const std::system_error& failure) {
    error = to_boost_error(failure.code());
    return nullptr;
  }
  // Like a real board after reset, the firmware loses bytes until it enables its receiver: the stream is
  // ready when it has (the virtual counterpart of SerialOptions::boot_wait).
  const auto deadline = SteadyClock::now() + kBootLimit;
  while (!stream->board_->uart().rx_enabled) {
    if (SteadyClock::now() >= deadline) {
      error = make_error_code(TransportError::boot_timeout);
      return nullptr;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  error = error_code();
  return stream;
}

std::shared_ptr<VirtualUnoStream> VirtualUnoStream::open(executor_type executor, VirtualUnoOptions options) {
  const std::string name = options.firmware.string();
  error_code error;
  auto stream = open(std::move(executor), std::move(options), error);
  if (error) throw boost::system::system_error(error, "open virtual Uno " + name);
  return stream;
}

std::shared_ptr<VirtualUnoStream> VirtualUnoStream::attach(executor_type executor, VirtualUno& board) {
  // Non-owning: the caller keeps the board alive.
  return std::make_shared<VirtualUnoStream>(std::move(executor), std::shared_ptr<VirtualUno>(&board, [](VirtualUno*) {}),
                                            false);
}

std::shared_ptr<VirtualUnoStream> VirtualUnoStream::attach_ring(executor_type executor, VirtualUno& first,
                                                                VirtualUno& last) {
  auto keep = [](VirtualUno*) {};  // non-owning, as attach()
  return std::make_shared<VirtualUnoStream>(std::move(executor), std::shared_ptr<VirtualUno>(&first, keep),
                                            std::shared_ptr<VirtualUno>(&last, keep), false);
}

VirtualUnoStream::VirtualUnoStream(executor_type executor, std::shared_ptr<VirtualUno> board, bool owns_board)
    : VirtualUnoStream(std::move(executor), board, board, owns_board) {}

VirtualUnoStream::VirtualUnoStream(executor_type executor, std::shared_ptr<VirtualUno> board,
                                   std::shared_ptr<VirtualUno> source, bool owns_board)
    : ByteStream(std::move(executor)),
      board_(std::move(board)),
      source_(std::move(source)),
      owns_board_(owns_board),
      inbox_(std::make_shared<Inbox>(strand())) {
  // The handler holds the inbox, not the stream: it may run while the stream is being destroyed.
  source_->set_output_handler([inbox = inbox_](const std::uint8_t* data, std::size_t size) { inbox->receive(data, size); });
}

VirtualUnoStream::~VirtualUnoStream() {
  source_->set_output_handler({});  // once it returns, the handler never runs again
  {
    std::lock_guard lock(inbox_->mutex);
    inbox_->closed = true;
    inbox_->reader = IoHandler();  // its target is this stream's buffer
  }
  if (owns_board_) board_->stop();
}

std::uint64_t VirtualUnoStream::discarded() const {
  std::lock_guard lock(inbox_->mutex);
  return inbox_->discarded;
}

std::string VirtualUnoStream::description() const {
  if (source_ != board_) {
    return "virtual Uno ring " + board_->options().name + " -> ... -> " + source_->options().name;
  }
  return "virtual Uno " + board_->options().firmware.filename().string();
}

void VirtualUnoStream::do_read(asio::mutable_buffer buffer, IoHandler handler) {
  Inbox& inbox = *inbox_;
  std::unique_lock lock(inbox.mutex);
  if (inbox.closed) {
    lock.unlock();
    inbox.complete(std::move(handler), asio::error::operation_aborted, 0);
    return;
  }
  inbox.read_target = buffer;
  if (inbox.bytes.empty()) {
    inbox.reader = std::move(handler);
    return;
  }
  const std::size_t served = inbox.serve();
  lock.unlock();
  inbox.complete(std::move(handler), error_code(), served);
}

void VirtualUnoStream::do_write(asio::const_buffer buffer, IoHandler handler) {
  board_->write(std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(buffer.data()), buffer.size()));
  asio::post(strand(), [handler = std::move(handler), size = buffer.size()]() mutable { handler(error_code(), size); });
}

void VirtualUnoStream::do_close(error_code& error) {
  error = error_code();
  source_->set_output_handler({});
  IoHandler reader;
  {
    std::lock_guard lock(inbox_->mutex);
    inbox_->closed = true;
    reader = std::move(inbox_->reader);
  }
  if (reader) inbox_->complete(std::move(reader), asio::error::operation_aborted, 0);
  if (owns_board_) board_->stop();
}

}  // namespace tether::transports
