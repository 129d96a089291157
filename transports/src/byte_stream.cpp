#include "tether/transports/byte_stream.hpp"

#include <boost/asio/error.hpp>

#include <algorithm>
#include <cstring>
#include <future>

namespace tether::transports {

ByteStream::ByteStream(executor_type executor, std::size_t read_ahead)
    : executor_(std::move(executor)),
      strand_(asio::make_strand(executor_)),
      read_ahead_(read_ahead == 0 ? 1 : read_ahead),
      deadline_timer_(strand_) {}

ByteStream::~ByteStream() {
  // Like an asio object: a read still pending completes with operation_aborted, never silently.
  if (pending_read_) {
    asio::post(executor_, [handler = std::move(pending_read_->handler)]() mutable {
      handler(asio::error::operation_aborted, 0);
    });
  }
}

void ByteStream::preload(const std::uint8_t* data, std::size_t size) {
  const std::size_t kept = std::min(size, read_ahead_.size() - ahead_end_);
  std::copy_n(data, kept, read_ahead_.data() + ahead_end_);
  ahead_end_ += kept;
}

void ByteStream::start_user_read(std::vector<asio::mutable_buffer> buffers, SteadyClock::time_point deadline,
                                 IoHandler handler) {
  asio::dispatch(strand_, [this, self = shared_from_this(), buffers = std::move(buffers), deadline,
                           handler = std::move(handler)]() mutable {
    if (pending_read_) {
      asio::post(strand_, [handler = std::move(handler)]() mutable {
        handler(make_error_code(TransportError::read_in_progress), 0);
      });
      return;
    }
    std::size_t wanted = 0;
    for (const auto& buffer : buffers) wanted += buffer.size();
    // Completions never run inside the initiating call: post even when the answer is known now.
    if (wanted == 0 || ahead_begin_ != ahead_end_ || !open_ || !notices_.empty() ||
        (device_error_ && !device_read_in_flight_)) {
      error_code error;
      std::size_t size = 0;
      if (wanted == 0) {
      } else if (ahead_begin_ != ahead_end_) {
        size = take_buffered(buffers);
      } else if (!open_) {
        error = asio::error::operation_aborted;
      } else if (!notices_.empty()) {
        error = take_notice();
      } else {
        error = device_error_;
      }
      asio::post(strand_, [handler = std::move(handler), error, size]() mutable { handler(error, size); });
      return;
    }
    pending_read_ = std::make_unique<PendingRead>(PendingRead{std::move(buffers), std::move(handler)});
    const std::uint64_t generation = ++read_generation_;
    if (deadline != SteadyClock::time_point::max()) {
      deadline_timer_.expires_at(deadline);
      deadline_timer_.async_wait([this, weak = weak_from_this(), generation](error_code error) {
        const auto alive = weak.lock();
        // Stale when the read completed first, even if a newer read is pending by now.
        if (!alive || error || !pending_read_ || generation != read_generation_) return;
        // The device read stays in flight; whatever it brings is kept in the read-ahead buffer.
        complete_pending_read(make_error_code(TransportError::timed_out));
      });
    }
    fill_read_ahead();
  });
}

void ByteStream::fill_read_ahead() {
  // A notice waits for its reader: bytes read now would come after it, though they belong after it.
  if (device_read_in_flight_ || !open_ || device_error_ || !notices_.empty()) return;
  if (ahead_begin_ == ahead_end_) ahead_begin_ = ahead_end_ = 0;
  if (ahead_end_ == read_ahead_.size()) return;  // full: bounded, the reader must consume first
  device_read_in_flight_ = true;
  // Weak: the read-ahead must not keep a stream alive that nobody reads any more (no user read pending).
  do_read(asio::buffer(read_ahead_.data() + ahead_end_, read_ahead_.size() - ahead_end_),
          [weak = weak_from_this()](error_code error, std::size_t size) {
            if (const auto self = weak.lock()) self->on_device_read(error, size);
          });
}

void ByteStream::on_device_read(error_code error, std::size_t size) {
  device_read_in_flight_ = false;
  ahead_end_ += size;
  if (error == TransportError::disconnected || error == TransportError::reconnected) {
    add_notice(error);
  } else if (error && error != asio::error::operation_aborted) {
    device_error_ = error;
  }
  if (!pending_read_) return;
  if (ahead_begin_ != ahead_end_) {
    complete_pending_read(error_code());
  } else if (!open_) {
    complete_pending_read(asio::error::operation_aborted);
  } else if (!notices_.empty()) {
    complete_pending_read(take_notice());
  } else if (device_error_) {
    complete_pending_read(device_error_);
  } else {
    fill_read_ahead();  // e.g. aborted underneath by a write deadline: read on
  }
}

void ByteStream::complete_pending_read(error_code error) {
  std::unique_ptr<PendingRead> read = std::move(pending_read_);
  deadline_timer_.cancel();
  const std::size_t size = error ? 0 : take_buffered(read->buffers);
  read->handler(error, size);
}

void ByteStream::add_notice(const error_code& notice) {
  // Outages alternate down, up, down...: an up still unread followed by a down cancels out (the reader
  // never saw the link back), so at most [down, up] waits.
  if (notice == TransportError::disconnected && !notices_.empty() && notices_.back() == TransportError::reconnected) {
    notices_.pop_back();
    return;
  }
  if (notices_.size() < 2) notices_.push_back(notice);
}

error_code ByteStream::take_notice() {
  const error_code notice = notices_.front();
  notices_.erase(notices_.begin());
  return notice;
}

std::size_t ByteStream::take_buffered(const std::vector<asio::mutable_buffer>& buffers) {
  const std::size_t copied =
      asio::buffer_copy(buffers, asio::buffer(read_ahead_.data() + ahead_begin_, ahead_end_ - ahead_begin_));
  ahead_begin_ += copied;
  return copied;
}

void ByteStream::start_user_write(asio::const_buffer buffer, IoHandler handler) {
  asio::dispatch(strand_, [this, self = shared_from_this(), buffer, handler = std::move(handler)]() mutable {
    if (!open_) {
      asio::post(strand_, [handler = std::move(handler)]() mutable { handler(asio::error::operation_aborted, 0); });
      return;
    }
    if (buffer.size() == 0) {
      asio::post(strand_, [handler = std::move(handler)]() mutable { handler(error_code(), 0); });
      return;
    }
    do_write(buffer, std::move(handler));
  });
}

void ByteStream::close(error_code& error) {
  error = error_code();
  if (!open_.exchange(false)) return;
  // The close runs on the strand, so it is ordered with the operations in flight. When no thread runs the
  // executor (e.g. at shutdown), nothing would ever run it: after a short wait the caller closes the device
  // itself. The claim makes sure exactly one of the two does it.
  auto claimed = std::make_shared<std::atomic<bool>>(false);
  auto result = std::make_shared<std::promise<error_code>>();
  auto done = result->get_future();
  auto close_on_strand = [this, self = shared_from_this(), claimed, result]() {
    if (claimed->exchange(true)) {
      // Closed by the caller meanwhile: only finish a read that waits on nothing.
      if (pending_read_ && !device_read_in_flight_) complete_pending_read(asio::error::operation_aborted);
      return;
    }
    error_code close_error;
    do_close(close_error);
    if (pending_read_ && !device_read_in_flight_) complete_pending_read(asio::error::operation_aborted);
    result->set_value(close_error);
  };
  if (strand_.running_in_this_thread()) {
    close_on_strand();
  } else {
    asio::dispatch(strand_, close_on_strand);
  }
  if (done.wait_for(std::chrono::milliseconds(250)) == std::future_status::ready) {
    error = done.get();
    return;
  }
  if (!claimed->exchange(true)) {
    do_close(error);
    // Pending completions were posted to the strand; they run if the executor ever runs again.
    asio::post(strand_, [this, self = shared_from_this()] {
      if (pending_read_ && !device_read_in_flight_) complete_pending_read(asio::error::operation_aborted);
    });
    return;
  }
  error = done.get();  // the strand claimed it just now
}

void ByteStream::close() {
  error_code error;
  close(error);
  if (error) throw boost::system::system_error(error, "close " + description());
}

std::size_t ByteStream::read_some(asio::mutable_buffer buffer, SteadyClock::duration timeout, error_code& error) {
  if (strand_.running_in_this_thread()) {
    error = make_error_code(TransportError::would_deadlock);
    return 0;
  }
  const auto deadline = timeout == SteadyClock::duration::max() ? SteadyClock::time_point::max()
                                                                : SteadyClock::now() + timeout;
  std::promise<std::pair<error_code, std::size_t>> done;
  auto result = done.get_future();
  async_read_some(buffer, deadline, [&done](error_code e, std::size_t n) { done.set_value({e, n}); });
  const auto [read_error, size] = result.get();
  error = read_error;
  return size;
}

std::size_t ByteStream::read_some(asio::mutable_buffer buffer, SteadyClock::duration timeout) {
  error_code error;
  const std::size_t size = read_some(buffer, timeout, error);
  if (error) throw boost::system::system_error(error, "read " + description());
  return size;
}

std::size_t ByteStream::write(asio::const_buffer buffer, error_code& error) {
  if (strand_.running_in_this_thread()) {
    error = make_error_code(TransportError::would_deadlock);
    return 0;
  }
  std::size_t total = 0;
  error = error_code();
  while (total < buffer.size() && !error) {
    std::promise<std::pair<error_code, std::size_t>> done;
    auto result = done.get_future();
    async_write_some(buffer + total, [&done](error_code e, std::size_t n) { done.set_value({e, n}); });
    const auto [write_error, size] = result.get();
    error = write_error;
    total += size;
  }
  return total;
}

std::size_t ByteStream::write(asio::const_buffer buffer, SteadyClock::time_point deadline, error_code& error) {
  if (strand_.running_in_this_thread()) {
    error = make_error_code(TransportError::would_deadlock);
    return 0;
  }
  std::size_t total = 0;
  error = error_code();
  while (total < buffer.size() && !error) {
    // Shared: after a deadline the completion may still arrive (aborted by the close) once we returned.
    auto done = std::make_shared<std::promise<std::pair<error_code, std::size_t>>>();
    auto result = done->get_future();
    async_write_some(buffer + total, [done](error_code e, std::size_t n) { done->set_value({e, n}); });
    if (result.wait_until(deadline) != std::future_status::ready) {
      error_code ignored;
      close(ignored);  // completes the write in flight with operation_aborted
      // The buffer is the caller's: do not return before the device stopped using it. The close above
      // completed the write, or will do so on the strand (its 250 ms fallback when nobody runs it).
      if (result.wait_for(std::chrono::seconds(1)) == std::future_status::ready) total += result.get().second;
      error = make_error_code(TransportError::timed_out);
      return total;
    }
    const auto [write_error, size] = result.get();
    error = write_error;
    total += size;
  }
  return total;
}

std::size_t ByteStream::write(asio::const_buffer buffer) {
  error_code error;
  const std::size_t size = write(buffer, error);
  if (error) throw boost::system::system_error(error, "write " + description());
  return size;
}

}  // namespace tether::transports
