#include "RSerial.h"

#include <cmath>
#include <stdexcept>

#include "link.hpp"
#include "tether/transports/serial_port_stream.hpp"

namespace romiserial {

RSerial::RSerial(const std::string& device, uint32_t baudrate, bool reset, std::shared_ptr<ILog> log)
    : link_(std::make_shared<Link>()), log_(std::move(log)) {
  link_->device = device;
  tether::transports::SerialOptions options = tether::transports::SerialOptions::arduino_uno();
  options.baud = baudrate;
  options.hang_up_on_close = reset;
  boost::system::error_code error;
  link_->stream = tether::transports::SerialPortStream::open(link_->io.executor(), device, options, error);
  if (error) {
    const std::string message = "RSerial: cannot open " + device + " at " + std::to_string(baudrate) +
                                " baud: " + error.message();
    if (log_) log_->error("%s", message.c_str());
    throw std::runtime_error(message);
  }
}

RSerial::~RSerial() = default;

void RSerial::set_timeout(double seconds) {
  const double milliseconds = seconds * 1000.0;
  std::lock_guard lock(link_->mutex);
  // NaN and negatives wait not at all; more than an hour is an hour.
  link_->timeout = std::chrono::milliseconds(milliseconds > 0.0 ? std::lround(std::fmin(milliseconds, 3600e3)) : 0);
}

bool RSerial::available() {
  std::lock_guard lock(link_->mutex);
  if (link_->taken) return false;
  if (link_->pending) return true;
  char byte = 0;
  boost::system::error_code error;
  if (link_->stream->read_some(boost::asio::buffer(&byte, 1), link_->timeout, error) != 1 || error) return false;
  link_->pending = byte;
  return true;
}

bool RSerial::read(char& c) {
  std::lock_guard lock(link_->mutex);
  if (link_->taken) return false;
  if (link_->pending) {
    c = *link_->pending;
    link_->pending.reset();
    return true;
  }
  boost::system::error_code error;
  return link_->stream->read_some(boost::asio::buffer(&c, 1), link_->timeout, error) == 1 && !error;
}

bool RSerial::write(char c) {
  std::lock_guard lock(link_->mutex);
  if (link_->taken) return false;
  boost::system::error_code error;
  link_->stream->write(boost::asio::buffer(&c, 1), error);
  if (error && log_) log_->error("RSerial::write on %s: %s", link_->device.c_str(), error.message().c_str());
  return !error;
}

const std::string& RSerial::device() const { return link_->device; }

}  // namespace romiserial
