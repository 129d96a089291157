#include "tether/transports/serial_port_stream.hpp"

#include <linux/serial.h>
#include <sys/ioctl.h>
#include <termios.h>

#include <boost/asio/error.hpp>
#include <boost/asio/write.hpp>

#include <algorithm>


namespace tether::transports {

SerialPortStream::SerialPortStream(executor_type executor, std::string path, const SerialOptions& options)
    : AsioObjectStream(std::move(executor)), options_(options), spec_{path, {}, {}}, path_(std::move(path)) {}

void SerialPortStream::start_open(executor_type executor, const std::string& path, const SerialOptions& options,
                                  OpenHandler handler) {
  start_open(std::move(executor), PortSpec{path, {}, {}}, options, std::move(handler));
}

void SerialPortStream::start_open(executor_type executor, const PortSpec& port, const SerialOptions& options,
                                  OpenHandler handler) {
  error_code error;
  const std::string path = resolve_port(port, error);
  auto stream = std::make_shared<SerialPortStream>(std::move(executor), path, options);
  stream->spec_ = port;
  if (error) {
    asio::post(stream->strand(), [handler = std::move(handler), error]() mutable { handler(error, nullptr); });
    return;
  }
  const SteadyClock::time_point opened = SteadyClock::now();
  stream->object_.open(path, error);  // open and configure are quick: no need to be asynchronous
  if (!error) stream->configure(error);
  if (error) {
    error_code ignored;
    stream->object_.close(ignored);
    asio::post(stream->strand(), [handler = std::move(handler), error]() mutable { handler(error, nullptr); });
    return;
  }
  asio::dispatch(stream->strand(), [stream, opened, handler = std::move(handler)]() mutable {
    stream->boot(opened, [stream, handler = std::move(handler)](error_code boot_error) mutable {
      if (boot_error) {
        error_code ignored;
        stream->close(ignored);
        handler(boot_error, nullptr);
        return;
      }
      stream->after_boot_wait(std::move(handler));
    });
  });
}

void SerialPortStream::after_boot_wait(OpenHandler handler) {
  if (options_.ready_banner.empty()) {
    asio::post(strand(), [self = std::static_pointer_cast<SerialPortStream>(shared_from_this()),
                          handler = std::move(handler)]() mutable { handler(error_code(), std::move(self)); });
    return;
  }
  await_banner(std::make_shared<std::string>(), SteadyClock::now() + options_.boot_timeout, std::move(handler));
}

// --- boot -------------------------------------------------------------------------------------------------

// The board was opened at `opened` (it may be resetting now): wait for it as `options_.boot` says, then
// `done` (on the strand). An error (the port vanished meanwhile) ends the wait early.
void SerialPortStream::boot(SteadyClock::time_point opened, BootHandler done) {
  replay_.clear();
  const bool waits = options_.boot != BootMode::none && options_.boot_wait.count() > 0;
  if (waits && options_.boot == BootMode::detect && options_.boot_signature.usable()) {
    // Bytes queued before this open (a pty keeps what a board printed while nobody had it open) are no
    // announcement of the boot this open caused: an old ResetEvent would end the wait at once, during the
    // bootloader, and the client's first bytes would be lost in it.
    ::tcflush(object_.native_handle(), TCIFLUSH);
    boot_done_ = std::move(done);
    detector_ = std::make_unique<BootDetector>(options_.boot_signature, options_.boot_wait, opened);
    boot_read();
    boot_apply(detector_->start());
    return;
  }
  BootReport report;
  report.mode = options_.boot;
  if (!waits) {
    boot_finish(report, error_code());
    done(error_code());
    return;
  }
  // fixed (or detect without a signature): the board is in its bootloader now; anything sent would be lost.
  boot_done_ = std::move(done);
  const std::uint64_t generation = ++boot_generation_;
  boot_timer_.expires_at(opened + options_.boot_wait);
  boot_timer_.async_wait([this, weak = weak_from_this(), generation, opened](error_code error) {
    const auto alive = weak.lock();
    if (!alive || error || closing_ || generation != boot_generation_) return;
    if (options_.discard_boot_noise) ::tcflush(object_.native_handle(), TCIFLUSH);
    BootReport waited;
    waited.mode = options_.boot;
    waited.outcome = BootOutcome::waited;
    waited.ready_after = std::chrono::duration_cast<std::chrono::milliseconds>(SteadyClock::now() - opened);
    boot_finish(waited, error_code());
  });
}

void SerialPortStream::boot_read() {
  object_.async_read_some(
      asio::buffer(boot_buffer_),
      asio::bind_executor(strand(), [this, weak = weak_from_this(), generation = boot_generation_](
                                        error_code error, std::size_t size) {
        const auto alive = weak.lock();
        if (!alive || closing_ || generation != boot_generation_ || !detector_) return;
        if (error) {
          // The port vanished while the board booted: the open (or re-open) fails with what the OS said.
          BootReport report = detector_->report();
          return boot_finish(report, error);
        }
        const BootDetector::Step step = detector_->on_bytes(
            std::string_view(reinterpret_cast<const char*>(boot_buffer_.data()), size), SteadyClock::now());
        if (!detector_->done()) boot_read();
        boot_apply(step);
      }));
}

void SerialPortStream::boot_apply(BootDetector::Step step) {
  using Action = BootDetector::Step::Action;
  if (step.action == Action::ready || step.action == Action::gave_up) {
    if (step.action == Action::ready) {
      replay_ = detector_->kept();
    } else if (options_.discard_boot_noise) {
      ::tcflush(object_.native_handle(), TCIFLUSH);  // what the fixed wait does
    }
    return boot_finish(detector_->report(), error_code());
  }
  if (step.action == Action::probe) {
    // Small and rare: a plain write; an error shows on the read (the port vanished).
    error_code ignored;
    asio::write(object_, asio::buffer(options_.boot_signature.probe), ignored);
  }
  boot_timer_.expires_at(step.wake);
  boot_timer_.async_wait([this, weak = weak_from_this(), generation = boot_generation_](error_code error) {
    const auto alive = weak.lock();
    if (!alive || error || closing_ || generation != boot_generation_ || !detector_) return;
    boot_apply(detector_->on_timer(SteadyClock::now()));
  });
}

void SerialPortStream::boot_finish(BootReport report, const error_code& error) {
  ++boot_generation_;  // the detection's read and timer, still pending, find they are stale
  if (detector_) {
    error_code ignored;
    boot_timer_.cancel();
    object_.cancel(ignored);  // the detection's read: the client's reads start afresh
    detector_.reset();
  }
  if (!error) {
    std::lock_guard lock(mutex_);
    counters_.last_boot = report;
  }
  if (auto done = std::move(boot_done_)) done(error);
}

BootReport SerialPortStream::boot_report() const {
  std::lock_guard lock(mutex_);
  return counters_.last_boot;
}

void SerialPortStream::await_banner(std::shared_ptr<std::string> seen, SteadyClock::time_point deadline,
                                    OpenHandler handler) {
  // One byte at a time through the read-ahead: whatever follows the banner stays buffered, in order.
  async_read_some(
      asio::buffer(&banner_byte_, 1), deadline,
      [self = std::static_pointer_cast<SerialPortStream>(shared_from_this()), seen, deadline,
       handler = std::move(handler)](error_code error, std::size_t size) mutable {
        if (error) {
          if (error == make_error_code(TransportError::timed_out)) error = make_error_code(TransportError::boot_timeout);
          error_code ignored;
          self->close(ignored);
          handler(error, nullptr);
          return;
        }
        seen->append(reinterpret_cast<const char*>(&self->banner_byte_), size);
        const std::string& banner = self->options_.ready_banner;
        if (seen->size() >= banner.size() && seen->compare(seen->size() - banner.size(), banner.size(), banner) == 0) {
          handler(error_code(), std::move(self));
          return;
        }
        if (seen->size() > 4 * banner.size() + 256) seen->erase(0, seen->size() - banner.size());
        self->await_banner(std::move(seen), deadline, std::move(handler));
      });
}

std::shared_ptr<SerialPortStream> SerialPortStream::open(executor_type executor, const std::string& path,
                                                         const SerialOptions& options, error_code& error) {
  auto result = async_open(std::move(executor), path, options, asio::use_future);
  return get_or_error(result, error);
}

std::shared_ptr<SerialPortStream> SerialPortStream::open(executor_type executor, const std::string& path,
                                                         const SerialOptions& options) {
  error_code error;
  auto stream = open(std::move(executor), path, options, error);
  if (error) throw boost::system::system_error(error, "open serial port " + path);
  return stream;
}

void SerialPortStream::configure(error_code& error) {
  // asio's open already puts the line in raw mode; make 8N1 and the rate explicit.
  object_.set_option(asio::serial_port::baud_rate(options_.baud), error);
  if (error) {
    error = make_error_code(TransportError::invalid_option);
    return;
  }
  object_.set_option(asio::serial_port::character_size(8), error);
  if (!error) object_.set_option(asio::serial_port::parity(asio::serial_port::parity::none), error);
  if (!error) object_.set_option(asio::serial_port::stop_bits(asio::serial_port::stop_bits::one), error);
  if (!error) object_.set_option(asio::serial_port::flow_control(asio::serial_port::flow_control::none), error);
  if (error) return;
  const int fd = object_.native_handle();
  if (options_.exclusive && ::ioctl(fd, TIOCEXCL) != 0) {
    error = error_code(errno, boost::system::system_category());
    return;
  }
  termios attributes{};
  if (::tcgetattr(fd, &attributes) == 0) {
    if (options_.hang_up_on_close) {
      attributes.c_cflag |= HUPCL;
    } else {
      attributes.c_cflag &= ~static_cast<tcflag_t>(HUPCL);
    }
    ::tcsetattr(fd, TCSANOW, &attributes);
  }
  if (options_.low_latency) {
    // Best effort: USB-serial drivers support it, ptys do not. low_latency_applied() tells.
    serial_struct serial{};
    if (::ioctl(fd, TIOCGSERIAL, &serial) == 0) {
      serial.flags = static_cast<int>(static_cast<unsigned>(serial.flags) | static_cast<unsigned>(ASYNC_LOW_LATENCY));
      low_latency_applied_ = ::ioctl(fd, TIOCSSERIAL, &serial) == 0;
    }
  }
}

std::string SerialPortStream::description() const {
  return "serial " + path() + " " + std::to_string(options_.baud) + " 8N1";
}

std::string SerialPortStream::path() const {
  std::lock_guard lock(mutex_);
  return path_;
}

// --- supervision ------------------------------------------------------------------------------------------

const char* to_string(LinkEvent::Kind kind) {
  switch (kind) {
    case LinkEvent::Kind::down: return "down";
    case LinkEvent::Kind::up: return "up";
    case LinkEvent::Kind::gave_up: return "gave up";
  }
  return "unknown";
}

void SerialPortStream::add_link_handler(std::function<void(const LinkEvent&)> handler) {
  std::lock_guard lock(mutex_);
  handlers_.push_back(std::move(handler));
}

LinkCounters SerialPortStream::link_counters() const {
  std::lock_guard lock(mutex_);
  LinkCounters counters = counters_;
  if (outage_running_) {
    counters.time_down += std::chrono::duration_cast<std::chrono::milliseconds>(SteadyClock::now() - down_since_);
  }
  return counters;
}

void SerialPortStream::do_read(asio::mutable_buffer buffer, IoHandler handler) {
  if (!owed_.empty()) {
    const error_code notice = owed_.front();
    owed_.pop_front();
    asio::post(strand(), [handler = std::move(handler), notice]() mutable { handler(notice, 0); });
    return;
  }
  if (!replay_.empty() && !down_) {
    const std::size_t size = std::min(buffer.size(), replay_.size());
    std::copy_n(replay_.data(), size, static_cast<char*>(buffer.data()));
    replay_.erase(0, size);
    asio::post(strand(), [handler = std::move(handler), size]() mutable { handler(error_code(), size); });
    return;
  }
  if (gave_up_) {
    asio::post(strand(), [handler = std::move(handler), error = gave_up_]() mutable { handler(error, 0); });
    return;
  }
  if (down_) {
    parked_ = std::make_unique<ParkedRead>(ParkedRead{std::move(handler)});
    return;
  }
  read_in_flight_ = true;
  object_.async_read_some(
      buffer, asio::bind_executor(strand(), [this, weak = weak_from_this(), connection = connection_,
                                             handler = std::move(handler)](error_code error, std::size_t size) mutable {
        const auto alive = weak.lock();
        if (!alive) return handler(error, size);
        if (error && supervised() && !closing_) {
          on_io_error(connection, error);  // while still in flight: this completion carries the notice
          error = make_error_code(TransportError::disconnected);
        }
        read_in_flight_ = false;
        handler(error, size);
      }));
}

void SerialPortStream::do_write(asio::const_buffer buffer, IoHandler handler) {
  if (gave_up_ || down_) {
    const error_code error = gave_up_ ? gave_up_ : make_error_code(TransportError::disconnected);
    asio::post(strand(), [handler = std::move(handler), error]() mutable { handler(error, 0); });
    return;
  }
  object_.async_write_some(
      buffer, asio::bind_executor(strand(), [this, weak = weak_from_this(), connection = connection_,
                                             handler = std::move(handler)](error_code error, std::size_t size) mutable {
        const auto alive = weak.lock();
        if (!alive || !error || !supervised() || closing_) return handler(error, size);
        on_io_error(connection, error);
        handler(make_error_code(TransportError::disconnected), size);
      }));
}

void SerialPortStream::do_close(error_code& error) {
  closing_ = true;
  retry_timer_.cancel();
  boot_timer_.cancel();
  if (parked_) {
    asio::post(strand(), [handler = std::move(parked_->handler)]() mutable { handler(asio::error::operation_aborted, 0); });
    parked_.reset();
  }
  AsioObjectStream::do_close(error);
}

// A read or write of connection `connection` failed: the port is gone (unless an older connection's
// operation reports what is known already).
void SerialPortStream::on_io_error(std::uint64_t connection, const error_code& error) {
  if (connection != connection_ || down_) return;
  lose(error);
}

void SerialPortStream::lose(const error_code& error) {
  down_ = true;
  replay_.clear();
  ++connection_;
  error_code ignored;
  object_.close(ignored);  // a read in flight completes (aborted) and carries the notice
  if (!read_in_flight_) owe(make_error_code(TransportError::disconnected));
  attempts_ = 0;
  delay_ = options_.reconnect.first_delay;
  LinkEvent event;
  event.kind = LinkEvent::Kind::down;
  {
    std::lock_guard lock(mutex_);
    ++counters_.disconnects;
    counters_.up = false;
    outage_running_ = true;
    down_since_ = SteadyClock::now();
    event.path = path_;
  }
  event.reason = event.path + ": " + (error == asio::error::eof ? std::string("end of file (the port vanished)") : error.message());
  last_failure_ = event.reason;
  emit(event);
  schedule_attempt();
}

void SerialPortStream::owe(const error_code& notice) {
  // As in the base stream: an owed up followed by a down cancels out; at most [down, up].
  if (notice == TransportError::disconnected && !owed_.empty() && owed_.back() == TransportError::reconnected) {
    owed_.pop_back();
    return;
  }
  if (owed_.size() < 2) owed_.push_back(notice);
}

void SerialPortStream::schedule_attempt() {
  retry_timer_.expires_after(delay_);
  retry_timer_.async_wait([this, weak = weak_from_this()](error_code error) {
    const auto alive = weak.lock();
    if (!alive || error || closing_) return;
    attempt();
  });
}

void SerialPortStream::attempt() {
  ++attempts_;
  error_code error;
  std::string message;
  const std::string path = resolve_port(spec_, error, &message);
  if (error) return retry_later(message);
  const SteadyClock::time_point opened = SteadyClock::now();
  object_.open(path, error);
  if (!error) configure(error);
  if (error) {
    error_code ignored;
    object_.close(ignored);
    return retry_later(path + ": " + error.message());
  }
  {
    std::lock_guard lock(mutex_);
    path_ = path;
  }
  boot(opened, [this, weak = weak_from_this(), path](error_code boot_error) {
    const auto alive = weak.lock();
    if (!alive || closing_) return;
    if (!boot_error) return become_up();
    error_code ignored;
    object_.close(ignored);
    retry_later(path + ": " + boot_error.message());
  });
}

void SerialPortStream::retry_later(std::string reason) {
  last_failure_ = std::move(reason);
  const ReconnectOptions& reconnect = options_.reconnect;
  if (reconnect.max_attempts != 0 && attempts_ >= reconnect.max_attempts) {
    gave_up_ = make_error_code(TransportError::reconnect_limit);
    LinkEvent event;
    event.kind = LinkEvent::Kind::gave_up;
    event.reason = last_failure_;
    event.attempts = attempts_;
    {
      std::lock_guard lock(mutex_);
      const auto down_for = std::chrono::duration_cast<std::chrono::milliseconds>(SteadyClock::now() - down_since_);
      counters_.time_down += down_for;
      counters_.gave_up = true;
      outage_running_ = false;
      event.down_for = down_for;
      event.path = path_;
    }
    if (parked_) {
      auto parked = std::move(parked_);
      asio::post(strand(), [handler = std::move(parked->handler), error = gave_up_]() mutable { handler(error, 0); });
    }
    emit(event);
    return;
  }
  delay_ = std::min(delay_ * 2, std::max(reconnect.max_delay, reconnect.first_delay));
  schedule_attempt();
}

void SerialPortStream::become_up() {
  down_ = false;
  LinkEvent event;
  event.kind = LinkEvent::Kind::up;
  event.attempts = attempts_;
  {
    std::lock_guard lock(mutex_);
    const auto down_for = std::chrono::duration_cast<std::chrono::milliseconds>(SteadyClock::now() - down_since_);
    ++counters_.reconnects;
    counters_.time_down += down_for;
    counters_.up = true;
    outage_running_ = false;
    event.down_for = down_for;
    event.path = path_;
    event.boot = counters_.last_boot;
  }
  if (!parked_) {
    owe(make_error_code(TransportError::reconnected));
    emit(event);
    return;
  }
  // The notice first, then the event, both through the strand in that order: by the time a handler
  // sees `up`, the reader's completion is queued on the reader's executor, so a call the handler's
  // program makes after it (queued behind) finds the client up again.
  auto parked = std::move(parked_);
  asio::post(strand(), [handler = std::move(parked->handler)]() mutable {
    handler(make_error_code(TransportError::reconnected), 0);
  });
  asio::post(strand(), [this, self = shared_from_this(), event] { emit(event); });
}

void SerialPortStream::emit(const LinkEvent& event) {
  std::vector<std::function<void(const LinkEvent&)>> handlers;
  {
    std::lock_guard lock(mutex_);
    handlers = handlers_;
  }
  for (const auto& handler : handlers) handler(event);
}

}  // namespace tether::transports
