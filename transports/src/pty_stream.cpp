#include "tether/transports/pty_stream.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

namespace tether::transports {

PtyStream::PtyStream(executor_type executor, int master_fd, int slave_fd, std::string slave_path)
    : AsioObjectStream(std::move(executor), master_fd), slave_fd_(slave_fd), slave_path_(std::move(slave_path)) {}

PtyStream::~PtyStream() {
  if (slave_fd_ >= 0) ::close(slave_fd_);
}

void PtyStream::do_close(error_code& error) {
  AsioObjectStream::do_close(error);
  if (slave_fd_ >= 0) {
    ::close(slave_fd_);
    slave_fd_ = -1;
  }
}

std::shared_ptr<PtyStream> PtyStream::open(executor_type executor, error_code& error) {
  const auto os_error = [&error] { error = error_code(errno, boost::system::system_category()); };
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master < 0) {
    os_error();
    return nullptr;
  }
  char name[128];
  if (::grantpt(master) != 0 || ::unlockpt(master) != 0 || ::ptsname_r(master, name, sizeof name) != 0) {
    os_error();
    ::close(master);
    return nullptr;
  }
  const int slave = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  termios attributes{};
  if (slave < 0 || ::tcgetattr(slave, &attributes) != 0) {
    os_error();
    if (slave >= 0) ::close(slave);
    ::close(master);
    return nullptr;
  }
  ::cfmakeraw(&attributes);
  if (::tcsetattr(slave, TCSANOW, &attributes) != 0) {
    os_error();
    ::close(slave);
    ::close(master);
    return nullptr;
  }
  return std::make_shared<PtyStream>(std::move(executor), master, slave, name);
}

std::shared_ptr<PtyStream> PtyStream::open(executor_type executor) {
  error_code error;
  auto stream = open(std::move(executor), error);
  if (error) throw boost::system::system_error(error, "open pty");
  return stream;
}

}  // namespace tether::transports
