// ClientLink: the read loop, write queue, timer and close shared by the host codec clients.
#include "tether/client/client_link.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/error.hpp>
#include <boost/asio/write.hpp>


namespace tether::client {

ClientLink::ClientLink(std::shared_ptr<transports::ByteStream> stream, std::shared_ptr<LinkClock> clock)
    : stream_(std::move(stream)),
      executor_(stream_->get_executor()),
      strand_(asio::make_strand(executor_)),
      clock_(clock ? std::move(clock) : steady_link_clock()),
      timer_(clock_->make_timer(strand_)),
      read_buffer_(std::make_shared<ReadBuffer>()) {}

ClientLink::~ClientLink() = default;

void ClientLink::close() {
  if (closed_.exchange(true)) return;
  // Posted, not dispatched: close() may be called from a hook, in the middle of decoding.
  post_to_strand([this] {
    cancel_timer();
    on_closed();
  });
  error_code ignored;
  stream_->close(ignored);  // completes the pending read with operation_aborted: the loop ends
}

// --- reads -----------------------------------------------------------------------------------------------

void ClientLink::start_reading() { read(); }

bool ClientLink::link_down() const { return link_error_ == transports::TransportError::disconnected; }

void ClientLink::read() {
  if (closed_.load() || (link_error_ && !link_down())) return;
  std::shared_ptr<ReadBuffer> buffer = read_buffer_;
  stream_->async_read_some(
      asio::buffer(*buffer),
      asio::bind_executor(strand_, [weak = weak_from_this(), buffer](error_code error, std::size_t size) {
        if (const auto self = weak.lock()) self->on_read(error, size);
      }));
}

void ClientLink::on_read(const error_code& error, std::size_t size) {
  if (error == transports::TransportError::reconnected) {
    if (link_down() && !closed_.load()) {
      link_error_.clear();
      on_link_restored();
      if (!writing_) write_next();
    }
    read();
    return;
  }
  if (error) {
    fail(error);
    if (link_down()) read();  // the supervised stream says when the port is back
    return;
  }
  on_bytes(read_buffer_->data(), size);
  read();
}

// --- writes ----------------------------------------------------------------------------------------------

void ClientLink::write(Bytes bytes, WriteDone done) {
  writes_.push_back(WriteItem{std::move(bytes), std::move(done)});
  if (!writing_) write_next();
}

void ClientLink::abort_writes(const error_code& error) {
  std::deque<WriteItem> aborted = std::move(writes_);
  writes_.clear();
  for (auto& item : aborted) {
    if (item.done) item.done(error);
  }
}

void ClientLink::write_next() {
  if (writes_.empty() || closed_.load() || link_error_) {
    writing_ = false;
    abort_writes(asio::error::operation_aborted);
    return;
  }
  writing_ = true;
  current_write_ = std::move(writes_.front());
  writes_.pop_front();
  Bytes bytes = current_write_.bytes;
  asio::async_write(*stream_, asio::buffer(*bytes),
                    asio::bind_executor(strand_, [self = shared_from_this(), bytes](error_code error, std::size_t) {
                      self->on_written(error);
                    }));
}

void ClientLink::on_written(const error_code& error) {
  WriteItem done = std::move(current_write_);
  current_write_ = WriteItem();
  if (error) {
    writing_ = false;
    if (done.done) done.done(error);
    fail(error);                                   // on_link_failed may abort the queue with the error
    abort_writes(asio::error::operation_aborted);  // what is left (closed link) never starts
    return;
  }
  if (done.done) done.done(error_code());
  write_next();
}

// --- failure ---------------------------------------------------------------------------------------------

void ClientLink::fail(const error_code& error) {
  // A port that vanished is down until its stream reports it back; only a final error follows that.
  if (closed_.load() || (link_error_ && !link_down()) || (link_down() && error == link_error_)) return;
  link_error_ = error;
  cancel_timer();
  on_link_failed(error);
}

// --- the timer -------------------------------------------------------------------------------------------

void ClientLink::arm_timer(const Deadline& wakeup) {
  if (!wakeup.armed() || closed_.load()) {
    if (timer_armed_) timer_->cancel();
    timer_armed_ = false;
    return;
  }
  if (timer_armed_ && timer_at_ == wakeup.at()) return;
  timer_armed_ = true;
  timer_at_ = wakeup.at();
  // Weak, like the read loop: a LinkTimer may keep the pending wait's handler itself (VirtualUnoClock,
  // ManualClock), and the link owns its timer and its clock, so a strong capture is a cycle that outlives
  // an io_context stopped before the close's cancel_timer ran (LeakSanitizer saw it after passing tests).
  timer_->wait_until(wakeup.at(), [weak = weak_from_this()](error_code error) {
    if (error) return;  // re-armed or cancelled
    const auto self = weak.lock();
    if (!self) return;
    self->timer_armed_ = false;
    self->on_timer();
  });
}

void ClientLink::cancel_timer() {
  timer_->cancel();
  timer_armed_ = false;
}

}  // namespace tether::client
