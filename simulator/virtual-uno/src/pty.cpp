#include "pty.hpp"

#include <fcntl.h>
#include <sys/inotify.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace tether::transports::detail {

namespace {

speed_t speed_for(std::uint32_t baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 1000000: return B1000000;
    default: return B115200;
  }
}

}  // namespace

std::unique_ptr<Pty> Pty::open(std::uint32_t baud, std::error_code& error) {
  error.clear();
  std::unique_ptr<Pty> pty(new Pty());
  auto os_error = [&error]() -> std::unique_ptr<Pty> {
    error = std::error_code(errno, std::generic_category());
    return nullptr;
  };
  pty->master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (pty->master_ < 0) return os_error();
  if (::grantpt(pty->master_) != 0 || ::unlockpt(pty->master_) != 0) return os_error();
  char name[128];
  if (::ptsname_r(pty->master_, name, sizeof name) != 0) return os_error();
  pty->path_ = name;
  pty->slave_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (pty->slave_ < 0) return os_error();
  termios settings{};
  if (::tcgetattr(pty->slave_, &settings) != 0) return os_error();
  ::cfmakeraw(&settings);
  settings.c_cflag |= CLOCAL | CREAD;
  settings.c_cc[VMIN] = 1;
  settings.c_cc[VTIME] = 0;
  ::cfsetispeed(&settings, speed_for(baud));
  ::cfsetospeed(&settings, speed_for(baud));
  if (::tcsetattr(pty->slave_, TCSANOW, &settings) != 0) return os_error();
  const int flags = ::fcntl(pty->master_, F_GETFL);
  if (flags < 0 || ::fcntl(pty->master_, F_SETFL, flags | O_NONBLOCK) != 0) return os_error();
  return pty;
}

bool Pty::watch_opens(std::error_code& error) {
  error.clear();
  if (inotify_ >= 0) return true;
  inotify_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (inotify_ < 0 || ::inotify_add_watch(inotify_, path_.c_str(), IN_OPEN) < 0) {
    error = std::error_code(errno, std::generic_category());
    if (inotify_ >= 0) ::close(inotify_);
    inotify_ = -1;
    return false;
  }
  return true;
}

bool Pty::client_opened() {
  if (inotify_ < 0) return false;
  bool opened = false;
  alignas(inotify_event) char buffer[1024];
  for (;;) {
    const ssize_t got = ::read(inotify_, buffer, sizeof buffer);
    if (got <= 0) break;
    for (ssize_t at = 0; at + static_cast<ssize_t>(sizeof(inotify_event)) <= got;) {
      inotify_event event;
      std::memcpy(&event, buffer + at, sizeof event);
      if ((event.mask & IN_OPEN) != 0) opened = true;
      at += static_cast<ssize_t>(sizeof(inotify_event) + event.len);
    }
  }
  return opened;
}

Pty::~Pty() {
  if (inotify_ >= 0) ::close(inotify_);
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

std::size_t Pty::read_input(std::deque<std::uint8_t>& out, std::size_t limit) {
  std::size_t total = 0;
  std::uint8_t buffer[4096];
  while (total < limit) {
    const std::size_t want = std::min(sizeof buffer, limit - total);
    const ssize_t got = ::read(master_, buffer, want);
    if (got <= 0) break;  // EAGAIN: nothing more now (EIO cannot happen: we hold the slave open)
    out.insert(out.end(), buffer, buffer + got);
    total += static_cast<std::size_t>(got);
  }
  return total;
}

void Pty::write_output(const std::uint8_t* data, std::size_t size) {
  if (pending_.empty()) {
    const ssize_t put = ::write(master_, data, size);
    if (put > 0) {
      data += put;
      size -= static_cast<std::size_t>(put);
    }
  }
  pending_.insert(pending_.end(), data, data + size);
  if (pending_.size() > kPendingLimit) {
    const std::size_t excess = pending_.size() - kPendingLimit;
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(excess));
    discarded_ += excess;
  }
}

void Pty::flush() {
  while (!pending_.empty()) {
    std::uint8_t buffer[4096];
    const std::size_t count = std::min(sizeof buffer, pending_.size());
    std::copy_n(pending_.begin(), count, buffer);
    const ssize_t put = ::write(master_, buffer, count);
    if (put <= 0) return;
    pending_.erase(pending_.begin(), pending_.begin() + put);
  }
}

}  // namespace tether::transports::detail
