// Running the real `tether` program in tests (see tether_process.hpp).
#include "tether_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace tether::cli::testing {

using namespace std::chrono_literals;

std::vector<std::string> Outcome::lines() const {
  std::vector<std::string> result;
  std::istringstream stream(out);
  for (std::string line; std::getline(stream, line);) result.push_back(line);
  return result;
}

bool matches(std::string_view text, std::string_view pattern) {
  if (pattern.empty()) return text.empty();
  const char token = pattern.front();
  const std::string_view rest = pattern.substr(1);
  if (token == '*') {
    for (std::size_t skip = 0; skip <= text.size(); ++skip) {
      if (matches(text.substr(skip), rest)) return true;
    }
    return false;
  }
  if (token == '#' || token == '~') {
    auto in_class = [token](char c) { return token == '#' ? (c >= '0' && c <= '9') : c == ' '; };
    for (std::size_t run = 0; run < text.size() && in_class(text[run]); ++run) {
      if (matches(text.substr(run + 1), rest)) return true;
    }
    return false;
  }
  return !text.empty() && text.front() == token && matches(text.substr(1), rest);
}

Outcome run_tether(const std::vector<std::string>& arguments, const std::vector<std::string>& environment) {
  return run_program(TETHER_BINARY, arguments, environment);
}

Outcome run_program(const std::string& binary, const std::vector<std::string>& arguments,
                    const std::vector<std::string>& environment) {
  static std::atomic<int> counter{0};
  const auto err_path = std::filesystem::temp_directory_path() / ("tether_command_test_" + std::to_string(::getpid()) +
                                                                  "_" + std::to_string(counter++) + ".err");
  std::vector<std::string> argv = {"sh", "-c", "exec \"$@\" 2>\"$0\" </dev/null", err_path.string()};
  if (!environment.empty()) {
    argv.push_back("/usr/bin/env");
    argv.insert(argv.end(), environment.begin(), environment.end());
  }
  argv.push_back(binary);
  argv.insert(argv.end(), arguments.begin(), arguments.end());
  Outcome run;
  {
    ::tether::testing::ChildProcess child(argv, /*capture_stdout=*/true);
    while (const auto line = child.read_line(60s)) run.out += *line + "\n";
    const auto status = child.wait(60s);
    run.status = status ? *status : -1000;
  }
  std::ifstream err_file(err_path);
  std::stringstream err;
  err << err_file.rdbuf();
  run.err = err.str();
  std::filesystem::remove(err_path);
  return run;
}

std::filesystem::path firmware(const std::string& name) {
  return std::filesystem::path(TETHER_FIRMWARE_DIR) / (name + ".elf");
}

namespace {

std::vector<std::string> sim_command(const std::vector<std::string>& arguments) {
  std::vector<std::string> command = {TETHER_BINARY, "sim"};
  command.insert(command.end(), arguments.begin(), arguments.end());
  return command;
}

}  // namespace

SimBoard::SimBoard(const std::string& image) : SimBoard(std::vector<std::string>{firmware(image).string()}) {}

SimBoard::SimBoard(const std::vector<std::string>& arguments)
    : process_(sim_command(arguments), /*capture_stdout=*/true) {
  const auto line = process_.read_line(30s);
  if (!line || !line->starts_with("PTY ")) throw std::runtime_error("tether sim did not print its pty");
  pty_ = line->substr(4);
}

Terminal::Terminal(const std::string& program, const std::vector<std::string>& arguments) {
  master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) {
    throw std::system_error(errno, std::generic_category(), "posix_openpt");
  }
  char name[128];
  if (::ptsname_r(master_, name, sizeof name) != 0) throw std::system_error(errno, std::generic_category(), "ptsname");
  // Everything the child needs, prepared before fork (the child only makes system calls).
  std::vector<std::string> strings = {program};
  strings.insert(strings.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (std::string& text : strings) argv.push_back(text.data());
  argv.push_back(nullptr);
  const std::string slave_path = name;

  pid_ = ::fork();
  if (pid_ < 0) throw std::system_error(errno, std::generic_category(), "fork");
  if (pid_ == 0) {
    ::setsid();                                            // a new session without a terminal...
    const int slave = ::open(slave_path.c_str(), O_RDWR);  // ...whose controlling terminal this becomes
    if (slave < 0) ::_exit(126);
    ::ioctl(slave, TIOCSCTTY, 0);
    ::dup2(slave, STDIN_FILENO);
    ::dup2(slave, STDOUT_FILENO);
    ::dup2(slave, STDERR_FILENO);
    if (slave > STDERR_FILENO) ::close(slave);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  reader_ = std::thread([this] { read_loop(); });
}

Terminal::~Terminal() {
  if (!wait_exit(0ms)) {
    ::kill(pid_, SIGTERM);
    if (!wait_exit(5s)) {
      ::kill(pid_, SIGKILL);
      wait_exit(5s);
    }
  }
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  reader_.join();
  ::close(master_);
}

void Terminal::read_loop() {
  char buffer[4096];
  for (;;) {
    {
      const std::lock_guard lock(mutex_);
      if (stop_) break;
    }
    pollfd fd{master_, POLLIN, 0};
    const int ready = ::poll(&fd, 1, 50);
    if (ready <= 0) continue;
    const ssize_t size = ::read(master_, buffer, sizeof buffer);
    if (size < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (size <= 0) {
      // EIO: every slave descriptor is closed (the program ended): nothing more will come.
      const std::lock_guard lock(mutex_);
      closed_ = true;
      changed_.notify_all();
      break;
    }
    const std::lock_guard lock(mutex_);
    screen_.append(buffer, static_cast<std::size_t>(size));
    changed_.notify_all();
  }
}

void Terminal::type(std::string_view text) {
  while (!text.empty()) {
    const ssize_t written = ::write(master_, text.data(), text.size());
    if (written < 0) {
      if (errno == EINTR) continue;
      throw std::system_error(errno, std::generic_category(), "write to the terminal");
    }
    text.remove_prefix(static_cast<std::size_t>(written));
  }
}

bool Terminal::expect(std::string_view text, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  std::size_t found = std::string::npos;
  changed_.wait_for(lock, timeout, [&] {
    found = screen_.find(text, cursor_);
    return found != std::string::npos || closed_;
  });
  if (found == std::string::npos) found = screen_.find(text, cursor_);
  if (found == std::string::npos) return false;
  cursor_ = found + text.size();
  return true;
}

std::string Terminal::screen() const {
  const std::lock_guard lock(mutex_);
  return screen_;
}

std::optional<int> Terminal::wait_exit(std::chrono::milliseconds timeout) {
  if (status_) return status_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t done = ::waitpid(pid_, &status, WNOHANG);
    if (done == pid_) {
      status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
      // What the program wrote last may still be in the terminal: the screen is whole once the reader has
      // seen the terminal close (bounded, for a descendant that keeps it open).
      std::unique_lock lock(mutex_);
      changed_.wait_for(lock, 5s, [&] { return closed_; });
      return status_;
    }
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(5ms);
  }
}

}  // namespace tether::cli::testing
