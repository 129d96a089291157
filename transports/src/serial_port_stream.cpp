#include "tether/transports/serial_port_stream.hpp"

#include <linux/serial.h>
#include <sys/ioctl.h>
#include <termios.h>

#include <boost/asio/error.hpp>

#include <thread>
#include <vector>

namespace tether::transports {

SerialPortStream::SerialPortStream(executor_type executor, std::string path, const SerialOptions& options)
    : AsioObjectStream(std::move(executor)), path_(std::move(path)), options_(options) {}

std::shared_ptr<SerialPortStream> SerialPortStream::open(executor_type executor, const std::string& path,
                                                         const SerialOptions& options, error_code& error) {
  auto stream = std::make_shared<SerialPortStream>(std::move(executor), path, options);
  stream->object_.open(path, error);
  if (!error) stream->configure(error);
  if (!error) stream->wait_for_boot(error);
  if (error) {
    error_code ignored;
    stream->object_.close(ignored);
    return nullptr;
  }
  return stream;
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

void SerialPortStream::wait_for_boot(error_code& error) {
  const int fd = object_.native_handle();
  if (options_.boot_wait.count() > 0) std::this_thread::sleep_for(options_.boot_wait);
  if (!options_.ready_banner.empty()) {
    // Read directly from the fd: the stream is not yet shared with anybody, and blocking here is the point.
    const auto deadline = SteadyClock::now() + options_.boot_timeout;
    std::string seen;
    while (seen.find(options_.ready_banner) == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - SteadyClock::now());
      if (left.count() <= 0) {
        error = make_error_code(TransportError::boot_timeout);
        return;
      }
      fd_set readable;
      FD_ZERO(&readable);
      FD_SET(fd, &readable);
      timeval timeout{static_cast<time_t>(left.count() / 1000), static_cast<suseconds_t>((left.count() % 1000) * 1000)};
      const int ready = ::select(fd + 1, &readable, nullptr, nullptr, &timeout);
      if (ready < 0 && errno != EINTR) {
        error = error_code(errno, boost::system::system_category());
        return;
      }
      if (ready <= 0) continue;
      char chunk[256];
      const ssize_t got = ::read(fd, chunk, sizeof chunk);
      if (got < 0 && errno != EAGAIN && errno != EINTR) {
        error = error_code(errno, boost::system::system_category());
        return;
      }
      if (got == 0) {
        error = asio::error::eof;
        return;
      }
      if (got > 0) seen.append(chunk, static_cast<std::size_t>(got));
      if (seen.size() > 4096) seen.erase(0, seen.size() - options_.ready_banner.size());
    }
    // Bytes after the banner are real traffic: keep them for the first read.
    const std::size_t after = seen.find(options_.ready_banner) + options_.ready_banner.size();
    preload(reinterpret_cast<const std::uint8_t*>(seen.data()) + after, seen.size() - after);
    return;
  }
  if (options_.discard_boot_noise && options_.boot_wait.count() > 0) ::tcflush(fd, TCIFLUSH);
}

std::string SerialPortStream::description() const {
  return "serial " + path_ + " " + std::to_string(options_.baud) + " 8N1";
}

}  // namespace tether::transports
