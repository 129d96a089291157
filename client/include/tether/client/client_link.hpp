/// @file client_link.hpp
/// The asio plumbing every host codec client shares: one `transports::ByteStream`, one strand, one
/// continuous read loop, a FIFO write queue, one timer armed at an absolute `Millis` deadline, link-failure
/// detection and a close that never hangs. It is the heart of the client runtime (`Tether::client`,
/// `tether/client/`), which sits on the transports' byte streams and knows the calls, deadlines and events
/// that a stream does not. A client derives from `ClientLink` and keeps only its protocol logic
/// (decoding, session engine calls, queues of calls, events); `romi::Client`, `proxy::Client` and
/// `elcano::RingClient` are built this way, with their public fronts from `client_skeleton.hpp`.
///
/// Threading: the link runs everything on a strand of the stream's executor. Functions marked "strand"
/// must be called on it (from a hook, or from work posted with `post_to_strand`); the others may be called
/// from any thread. The hooks (`on_bytes`, `on_timer`, `on_link_failed`, `on_closed`) always run on the
/// strand, never inside the call that caused them (`close()` included).
///
/// Lifetime: create the derived client with `std::make_shared`, then start the read loop on the strand
/// (`post_to_strand([this] { start_reading(); })`). Handlers of writes and posted work hold the link
/// strongly and are owned by the io_context (released when they run or when it is destroyed). The read
/// loop and the timer hold it weakly, because a pending read is owned by the stream and a pending wait may
/// be owned by the timer or its clock (`ManualClock`, `VirtualUnoClock` keep the handler), all of which the
/// link owns: a strong capture would be a cycle that outlives an io_context that stopped. The read buffer is shared with the
/// pending read, so a read completing after the link died never writes into freed memory. Dropping the
/// last reference without `close()` destroys the link (and the stream) once no handler holds it.
///
/// Time: `now()` is the link's `LinkClock` in wrap-safe 32-bit milliseconds (`tether::Millis`), the clock
/// of the session engines: the steady clock unless the client's options inject another (tests use
/// `client::testing::ManualClock` and assert on simulated time). `arm_timer(deadline)` waits on a timer
/// of that clock; a deadline in the past fires at once.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>
#include <utility>

#include "tether/client/link_clock.hpp"
#include "tether/core/time.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::client {

/// Base of a host codec client: owns the stream's read loop, write queue, timer and close; see the file
/// overview. Not copyable; always owned by a `std::shared_ptr`.
class ClientLink : public std::enable_shared_from_this<ClientLink> {
 public:
  /// Names one asynchronous operation of the client (for its cancellation); never 0.
  using OperationId = std::uint64_t;
  /// Bytes to write; shared so a re-send needs no copy and the pending write keeps them alive.
  using Bytes = std::shared_ptr<const std::string>;
  /// Completion of one queued write. Contract:
  ///   1. Called exactly once on the strand, unless the link is destroyed with the write still queued.
  ///   2. With no error once all the bytes were written; with the stream's error when the write failed;
  ///      with `operation_aborted` when the write was dropped (closed, failed link, `abort_writes`).
  ///   3. Must not throw.
  using WriteDone = transports::UniqueFunction<void(error_code)>;
  /// Size of the shared read buffer (bytes handed to `on_bytes` at most at once).
  static constexpr std::size_t kReadBufferSize = 1024;

  ClientLink(const ClientLink&) = delete;
  ClientLink& operator=(const ClientLink&) = delete;
  /// Destroys the stream (a pending read completes with `operation_aborted` and finds no link).
  virtual ~ClientLink();

  /// The stream's executor: completions posted with `post_completion` run on it. Any thread.
  const asio::any_io_executor& executor() const { return executor_; }
  /// True on the strand (a blocking call from here would deadlock). Any thread.
  bool on_strand() const { return strand_.running_in_this_thread(); }
  /// False once `close()` was called. Any thread.
  bool is_open() const { return !closed_.load(); }

  /// Closes: marks the link closed, posts `on_closed` (after cancelling the timer) and closes the stream,
  /// which completes the pending read with `operation_aborted` and ends the loop. Idempotent, any thread,
  /// never waits for the device or for the strand.
  void close();

  /// A new operation's id. Any thread.
  OperationId new_operation() { return ++operations_; }
  /// Cancels operation `id`: posts `on_cancel(id)` to the strand. Any thread, never waits.
  void cancel(OperationId id) {
    post_to_strand([this, id] { on_cancel(id); });
  }

  /// The link's clock in wrap-safe milliseconds (the session engines' clock). Any thread.
  Millis now() const { return clock_->now(); }

  /// Posts `work` to the strand, holding the link until it ran. Any thread. `work` may be move-only.
  template <typename Work>
  void post_to_strand(Work work) {
    asio::post(strand_, [self = shared_from_this(), work = std::move(work)]() mutable { work(); });
  }

  /// Posts `handler(args...)` to the executor: never on the strand, never inside the calling function
  /// (what asio requires of a completion). Any thread. Arguments are moved into the posted call.
  template <typename Handler, typename... Args>
  void post_completion(Handler handler, Args... args) const {
    asio::post(executor_, [handler = std::move(handler), args = std::make_tuple(std::move(args)...)]() mutable {
      std::apply(handler, std::move(args));
    });
  }

 protected:
  /// Link over `stream` (not null) with its deadlines on `clock` (null: `steady_link_clock()`); nothing
  /// starts before `start_reading`.
  explicit ClientLink(std::shared_ptr<transports::ByteStream> stream, std::shared_ptr<LinkClock> clock = nullptr);

  /// Starts the continuous read loop. Strand, once.
  void start_reading();
  /// Queues `bytes` behind every earlier write (FIFO, one write on the stream at a time); `done`, when
  /// given, reports the outcome (see `WriteDone`). Strand.
  void write(Bytes bytes, WriteDone done = {});
  /// Completes every queued write not yet started with `error` (the write in progress finishes). Strand.
  void abort_writes(const error_code& error);
  /// Arms the timer at `wakeup` (`on_timer` runs then); a disarmed deadline, or a closed link, cancels it.
  /// Re-arming at the same instant keeps the pending wait. Strand.
  void arm_timer(const Deadline& wakeup);
  /// Cancels the timer. Strand.
  void cancel_timer();
  /// The first read or write error of the link (empty while it works); `TransportError::disconnected`
  /// while a supervised port is away (cleared when it is back). Strand.
  const error_code& link_error() const { return link_error_; }
  /// True while a supervised port is away (`link_error()` is `disconnected`). Strand.
  bool link_down() const;

  /// Bytes read from the stream, in order. Contract:
  ///   1. Runs on the strand after every successful read, with a view of the `size` bytes read, valid
  ///      only during the call.
  ///   2. The next read starts after it returns (unless the link closed or failed meanwhile).
  ///   3. Must not throw.
  virtual void on_bytes(const std::uint8_t* data, std::size_t size) = 0;
  /// The deadline given to `arm_timer` was reached. Contract:
  ///   1. Runs on the strand, once per arming; the timer counts as disarmed (re-arm from here).
  ///   2. Not called after `cancel_timer`, a re-arm at another instant, close or link failure (unless the
  ///      wait had already completed).
  ///   3. Must not throw.
  virtual void on_timer() = 0;
  /// The link failed: the first read or write error while open (EOF, unplugged device, ...). Contract:
  ///   1. Runs on the strand, at most once per link, and never after `close()`; `link_error()` holds
  ///      `error` and the timer was cancelled. Exception: a supervised port that vanished
  ///      (`TransportError::disconnected`, serial_port_stream.hpp) is not the end: the hook runs with it
  ///      once per outage, what waits fails with it, and new operations fail at once while `link_error()`
  ///      holds it; when the port is back, `link_error()` is cleared and `on_link_restored` runs. An outage
  ///      that ends for good (`reconnect_limit`) runs the hook again with that error.
  ///   2. No further read starts (but during an outage); queued writes are dropped (their `WriteDone` gets
  ///      `operation_aborted` when they would start, or whatever the hook passes to `abort_writes`).
  ///   3. Must not throw.
  virtual void on_link_failed(const error_code& error) = 0;
  /// A supervised port is back after an outage (the stream re-opened it): the session the device had is
  /// likely gone (an unplugged board lost power), so a client restarts what its codec's recovery needs.
  /// Runs on the strand; `link_error()` is clear again. Default: nothing (the codec's reset detection
  /// sees the rebooted device by itself). Must not throw.
  virtual void on_link_restored() {}
  /// `close()` was called. Contract:
  ///   1. Runs on the strand, exactly once, after the timer was cancelled; posted by `close()`, so it
  ///      never runs inside a hook that called `close()`.
  ///   2. `is_open()` is already false: the hook fails whatever waits (typically with `operation_aborted`).
  ///   3. Must not throw.
  virtual void on_closed() = 0;
  /// The application cancelled operation `id` (its token's cancellation slot). Contract:
  ///   1. Runs on the strand; the client completes that operation with `operation_aborted` if it is still
  ///      pending (queued or waiting for the device) and leaves every other operation alone.
  ///   2. An id that already completed, or that the client does not know, is ignored.
  ///   3. What was already written stays written: a device may still act on it (its late answer is stale).
  ///   4. Default: ignored (a client without cancellable operations); must not throw.
  virtual void on_cancel(OperationId id) { (void)id; }

 private:
  using ReadBuffer = std::array<std::uint8_t, kReadBufferSize>;
  struct WriteItem {
    Bytes bytes;
    WriteDone done;
  };

  void read();
  void on_read(const error_code& error, std::size_t size);
  void write_next();
  void on_written(const error_code& error);
  void fail(const error_code& error);

  std::shared_ptr<transports::ByteStream> stream_;
  asio::any_io_executor executor_;
  asio::strand<asio::any_io_executor> strand_;
  std::shared_ptr<LinkClock> clock_;
  std::unique_ptr<LinkTimer> timer_;

  // Strand only.
  bool timer_armed_ = false;
  Millis timer_at_ = 0;
  std::deque<WriteItem> writes_;
  WriteItem current_write_;
  bool writing_ = false;
  error_code link_error_;
  std::shared_ptr<ReadBuffer> read_buffer_;

  // Any thread.
  std::atomic<bool> closed_{false};
  std::atomic<OperationId> operations_{0};
};

/// Starts an operation with `start(handler)` and waits for its `void(error_code, Result)` completion; the
/// usual body of a client's blocking call. Returns false, with `error` set to
/// `transports::TransportError::would_deadlock` and `start` not called, on `link`'s strand (the completion could never
/// run); otherwise true with `error` and `result` from the completion. `start` receives a
/// `transports::UniqueFunction<void(error_code, Result)>` that must be called exactly once, from another thread or
/// from the executor.
template <typename Result, typename Start>
bool wait_for_completion(const ClientLink& link, Start&& start, error_code& error, Result& result) {
  if (link.on_strand()) {
    error = make_error_code(transports::TransportError::would_deadlock);
    return false;
  }
  std::promise<std::pair<error_code, Result>> done;
  auto future = done.get_future();
  std::forward<Start>(start)(transports::UniqueFunction<void(error_code, Result)>(
      [&done](error_code e, Result r) { done.set_value({e, std::move(r)}); }));
  auto [completion_error, value] = future.get();
  error = completion_error;
  result = std::move(value);
  return true;
}

/// A value written on a strand and read from any thread: what a client publishes of its strand state
/// (counters, session status) for its thread-safe getters.
template <typename T>
class Published {
 public:
  /// Publishes `value` (a copy). Any thread.
  void set(const T& value) {
    std::lock_guard lock(mutex_);
    value_ = value;
  }
  /// The last published value (default-constructed before the first `set`). Any thread.
  T get() const {
    std::lock_guard lock(mutex_);
    return value_;
  }

 private:
  mutable std::mutex mutex_;
  T value_{};
};

}  // namespace tether::client
