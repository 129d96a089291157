/// @file byte_stream.hpp
/// The one byte-stream interface that every codec client uses, whatever the link: serial port, TCP
/// (ser2net), pty, in-memory pair, virtual Uno, or a fault-injecting wrapper around any of them.
///
/// `ByteStream` models asio's AsyncReadStream and AsyncWriteStream, so asio's composed operations
/// (`async_read`, `async_write`, `async_read_until`) work on it, and every asynchronous operation takes a
/// completion token (a callback, `use_future`, `use_awaitable`, ...). On top of asio it adds:
///   - **per-operation deadlines**: `async_read_some(buffers, deadline, token)` completes with
///     `TransportError::timed_out` when no byte arrived in time. The read is not cancelled underneath:
///     bytes arriving later are kept for the next read, so a deadline never loses data and never aborts a
///     concurrent write (asio 1.74's `cancel()` would abort both directions);
///   - **blocking overloads** with `error_code&` and throwing variants, for tools and simple programs;
///   - `close()` that completes pending operations with `operation_aborted`, and a vanished device (EOF,
///     EIO) that completes them with that error: a caller is never left hanging;
///   - **outage notices** of a supervised device (a serial port that re-opens its board, serial_port_stream.hpp):
///     one read completes with `TransportError::disconnected` when the port vanishes, and later one with
///     `TransportError::reconnected` (no bytes) when it is back, before any byte of the new connection.
///     Unlike an error they are not sticky: read on after them.
///
/// Threading: the stream runs its completions on a strand of the executor it was created with, and its
/// public functions may be called from any thread. As with asio streams, start at most one read and one
/// write at a time (a second concurrent read fails with `TransportError::read_in_progress`).
///
/// Lifetime: streams are created by factories as `std::shared_ptr`. Dropping the last reference destroys
/// the stream; a read still pending then completes with `operation_aborted`. After a read ends at its
/// deadline the stream keeps one device read in flight (that is how late bytes are kept); like any pending
/// asio operation it keeps `io_context::run()` from returning until the stream is closed or destroyed.
///
/// Implementations derive from `ByteStream` and implement the three `do_*` hooks; the base class provides
/// the read-ahead buffer, deadlines, blocking calls and handler dispatch.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/asio/associated_executor.hpp>
#include <boost/asio/buffer.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/execution/outstanding_work.hpp>
#include <boost/asio/prefer.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/use_future.hpp>
#include <boost/system/error_code.hpp>
#include <boost/system/system_error.hpp>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tether/transports/transport_error.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::transports {

namespace asio = boost::asio;
using boost::system::error_code;

/// Clock of all transport deadlines.
using SteadyClock = std::chrono::steady_clock;

/// Wraps `handler` so that calling the result dispatches it to its associated executor (`fallback` when it
/// has none), which counts as having work until then: what asio requires of an initiating function.
/// Works with old- and new-style executors (strands of any_io_executor included).
template <typename Signature, typename Handler, typename Executor>
UniqueFunction<Signature> bind_to_associated_executor(Handler handler, const Executor& fallback) {
  auto tracked = asio::prefer(asio::get_associated_executor(handler, fallback),
                              asio::execution::outstanding_work.tracked);
  return [handler = std::move(handler), tracked = std::move(tracked)](auto... args) mutable {
    asio::dispatch(tracked, [handler = std::move(handler), args...]() mutable { handler(std::move(args)...); });
  };
}

/// Abstract byte stream with deadlines; see the file overview.
class ByteStream : public std::enable_shared_from_this<ByteStream> {
 public:
  /// Executor type (asio's type-erased I/O executor).
  using executor_type = asio::any_io_executor;
  /// Completion handler of the implementation hooks: called exactly once, on the stream's strand.
  using IoHandler = UniqueFunction<void(error_code, std::size_t)>;

  virtual ~ByteStream();
  ByteStream(const ByteStream&) = delete;
  ByteStream& operator=(const ByteStream&) = delete;

  /// The executor given at construction (completions run on a strand of it).
  executor_type get_executor() const noexcept { return executor_; }

  /// Reads at least one byte into `buffers` (asio AsyncReadStream). Signature: `void(error_code, size_t)`.
  template <typename MutableBufferSequence, typename ReadToken>
  auto async_read_some(const MutableBufferSequence& buffers, ReadToken&& token) {
    return async_read_some(buffers, SteadyClock::time_point::max(), std::forward<ReadToken>(token));
  }

  /// Reads at least one byte, or completes with `TransportError::timed_out` at `deadline`. Bytes that
  /// arrive after the deadline are kept for the next read.
  template <typename MutableBufferSequence, typename ReadToken>
  auto async_read_some(const MutableBufferSequence& buffers, SteadyClock::time_point deadline, ReadToken&& token) {
    return asio::async_initiate<ReadToken, void(error_code, std::size_t)>(
        [this](auto handler, const MutableBufferSequence& target, SteadyClock::time_point until) {
          start_user_read(to_buffers(target), until, wrap(std::move(handler)));
        },
        token, buffers, deadline);
  }

  /// Writes at least one byte of `buffers` (asio AsyncWriteStream). Signature: `void(error_code, size_t)`.
  template <typename ConstBufferSequence, typename WriteToken>
  auto async_write_some(const ConstBufferSequence& buffers, WriteToken&& token) {
    return asio::async_initiate<WriteToken, void(error_code, std::size_t)>(
        [this](auto handler, const ConstBufferSequence& source) {
          start_user_write(first_buffer(source), wrap(std::move(handler)));
        },
        token, buffers);
  }

  /// Blocking read of at least one byte, waiting at most `timeout`. Needs another thread to run the
  /// executor; called on the stream's own strand it fails with `TransportError::would_deadlock`.
  std::size_t read_some(asio::mutable_buffer buffer, SteadyClock::duration timeout, error_code& error);
  /// Blocking read of at least one byte, no deadline.
  std::size_t read_some(asio::mutable_buffer buffer, error_code& error) {
    return read_some(buffer, SteadyClock::duration::max(), error);
  }
  /// Blocking read; throws `boost::system::system_error`.
  std::size_t read_some(asio::mutable_buffer buffer, SteadyClock::duration timeout = SteadyClock::duration::max());
  /// Blocking write of all of `buffer` (loops over partial writes).
  std::size_t write(asio::const_buffer buffer, error_code& error);
  /// Blocking write of all of `buffer`; throws `boost::system::system_error`.
  std::size_t write(asio::const_buffer buffer);
  /// Blocking write of all of `buffer` that gives up at `deadline` (a device that stopped reading, a full
  /// pty): then `TransportError::timed_out` and the bytes written so far. Bytes handed to a device cannot
  /// be taken back, so the write still in flight is ended by closing the stream (the link is unusable:
  /// the device would get a cut frame); later operations fail with `operation_aborted`. Callable from any
  /// thread but the stream's strand (`TransportError::would_deadlock`).
  std::size_t write(asio::const_buffer buffer, SteadyClock::time_point deadline, error_code& error);

  /// Closes the stream; pending operations complete with `operation_aborted`. Idempotent. Runs on the
  /// stream's strand; when no thread runs the executor (shutdown), it closes the device directly after
  /// 250 ms, so it never hangs.
  void close(error_code& error);
  /// Closes the stream; throws on failure.
  void close();
  /// True until `close`.
  bool is_open() const { return open_.load(); }
  /// Human-readable description, e.g. "serial /dev/ttyACM0 115200 8N1".
  virtual std::string description() const = 0;

 protected:
  /// `executor`: where completions run (a strand of it); `read_ahead`: internal buffer size (> 0).
  explicit ByteStream(executor_type executor, std::size_t read_ahead = 4096);

  /// Puts `size` bytes at `data` in front of everything the device delivers (bytes an opener read past a
  /// boot banner, say). Only before the stream is shared; at most the read-ahead capacity is kept.
  void preload(const std::uint8_t* data, std::size_t size);

  /// The strand all hooks are called on and must complete on.
  const asio::strand<executor_type>& strand() const { return strand_; }

  /// Hook: start one read of up to `buffer.size()` bytes. Contract:
  ///   1. `handler` is called exactly once, on `strand()`, never from inside this call.
  ///   2. It reports at least one byte, or an error (EOF/vanished device as that error).
  ///   3. At most one read is started at a time.
  ///   4. `buffer` belongs to this stream: an implementation that parks the read somewhere outlasting the
  ///      stream (a shared channel) must withdraw it in its destructor.
  virtual void do_read(asio::mutable_buffer buffer, IoHandler handler) = 0;
  /// Hook: start one write of up to `buffer.size()` bytes; same contract as `do_read`.
  virtual void do_write(asio::const_buffer buffer, IoHandler handler) = 0;
  /// Hook: close the device; reads/writes in flight must complete with `operation_aborted`.
  virtual void do_close(error_code& error) = 0;

 private:
  struct PendingRead {
    std::vector<asio::mutable_buffer> buffers;
    IoHandler handler;
  };

  template <typename Sequence>
  static std::vector<asio::mutable_buffer> to_buffers(const Sequence& sequence) {
    std::vector<asio::mutable_buffer> result;
    for (auto it = asio::buffer_sequence_begin(sequence); it != asio::buffer_sequence_end(sequence); ++it) {
      result.emplace_back(*it);
    }
    return result;
  }
  template <typename Sequence>
  static asio::const_buffer first_buffer(const Sequence& sequence) {
    for (auto it = asio::buffer_sequence_begin(sequence); it != asio::buffer_sequence_end(sequence); ++it) {
      const asio::const_buffer buffer(*it);
      if (buffer.size() > 0) return buffer;
    }
    return asio::const_buffer();
  }
  template <typename Handler>
  IoHandler wrap(Handler handler) {
    return bind_to_associated_executor<void(error_code, std::size_t)>(std::move(handler), executor_);
  }

  void start_user_read(std::vector<asio::mutable_buffer> buffers, SteadyClock::time_point deadline, IoHandler handler);
  void start_user_write(asio::const_buffer buffer, IoHandler handler);
  void fill_read_ahead();
  void on_device_read(error_code error, std::size_t size);
  void complete_pending_read(error_code error);
  std::size_t take_buffered(const std::vector<asio::mutable_buffer>& buffers);
  void add_notice(const error_code& notice);
  error_code take_notice();

  executor_type executor_;
  asio::strand<executor_type> strand_;
  // Everything below is touched only on strand_.
  std::vector<std::uint8_t> read_ahead_;
  std::size_t ahead_begin_ = 0;
  std::size_t ahead_end_ = 0;
  bool device_read_in_flight_ = false;
  error_code device_error_;  // sticky: EOF, vanished device; delivered once the read-ahead is drained
  // Outage notices of a supervised device (disconnected, reconnected), each delivered once, in order,
  // after the bytes read before it; no device read starts while one waits.
  std::vector<error_code> notices_;
  std::unique_ptr<PendingRead> pending_read_;
  std::uint64_t read_generation_ = 0;  // identifies the pending read a deadline belongs to
  asio::steady_timer deadline_timer_;
  std::atomic<bool> open_{true};
};

}  // namespace tether::transports
