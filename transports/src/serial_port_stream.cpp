#include "tether/transports/serial_port_stream.hpp"

#include <linux/serial.h>
#include <sys/ioctl.h>
#include <termios.h>

#include <boost/asio/error.hpp>


namespace tether::transports {

SerialPortStream::SerialPortStream(executor_type executor, std::string path, const SerialOptions& options)
    : AsioObjectStream(std::move(executor)), path_(std::move(path)), options_(options) {}

void SerialPortStream::start_open(executor_type executor, const std::string& path, const SerialOptions& options,
                                  OpenHandler handler) {
  auto stream = std::make_shared<SerialPortStream>(std::move(executor), path, options);
  error_code error;
  stream->object_.open(path, error);  // open and configure are quick: no need to be asynchronous
  if (!error) stream->configure(error);
  if (error) {
    error_code ignored;
    stream->object_.close(ignored);
    asio::post(stream->strand(), [handler = std::move(handler), error]() mutable { handler(error, nullptr); });
    return;
  }
  if (options.boot_wait.count() == 0) {
    asio::dispatch(stream->strand(), [stream, handler = std::move(handler)]() mutable {
      stream->after_boot_wait(std::move(handler));
    });
    return;
  }
  // The board is in its bootloader now: anything sent would be lost.
  stream->boot_timer_.expires_after(options.boot_wait);
  stream->boot_timer_.async_wait([stream, handler = std::move(handler)](error_code) mutable {
    stream->after_boot_wait(std::move(handler));
  });
}

void SerialPortStream::after_boot_wait(OpenHandler handler) {
  if (options_.ready_banner.empty()) {
    if (options_.discard_boot_noise && options_.boot_wait.count() > 0) ::tcflush(object_.native_handle(), TCIFLUSH);
    asio::post(strand(), [self = std::static_pointer_cast<SerialPortStream>(shared_from_this()),
                          handler = std::move(handler)]() mutable { handler(error_code(), std::move(self)); });
    return;
  }
  await_banner(std::make_shared<std::string>(), SteadyClock::now() + options_.boot_timeout, std::move(handler));
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
  return "serial " + path_ + " " + std::to_string(options_.baud) + " 8N1";
}

}  // namespace tether::transports
