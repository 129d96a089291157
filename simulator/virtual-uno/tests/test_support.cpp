#include "test_support.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>
#include <thread>

#include "tether/testing/random_seed.hpp"

namespace tether::transports::test {

std::filesystem::path firmware_path(std::string_view name) { return std::filesystem::path(TETHER_FIRMWARE_DIR) / name; }

VirtualUnoOptions echo_options(std::uint64_t stream) {
  VirtualUnoOptions options;
  options.firmware = firmware_path("echo.elf");
  options.pacing = Pacing::fast;
  options.seed = FaultRandom::mix(testing::random_seed(), stream);
  return options;
}

std::size_t count_occurrences(std::string_view text, std::string_view needle) {
  std::size_t count = 0;
  for (std::size_t at = text.find(needle); at != std::string_view::npos; at = text.find(needle, at + needle.size())) {
    ++count;
  }
  return count;
}

// --- OutputRecorder -----------------------------------------------------------------------------------

OutputRecorder::OutputRecorder(VirtualUno& uno) : uno_(uno) {
  uno_.set_output_handler([this](const std::uint8_t* data, std::size_t size) {
    {
      std::lock_guard lock(mutex_);
      batches_.push_back(Batch{std::string(reinterpret_cast<const char*>(data), size), uno_.cycles()});
      text_.append(reinterpret_cast<const char*>(data), size);
    }
    changed_.notify_all();
  });
}

OutputRecorder::~OutputRecorder() { uno_.set_output_handler({}); }

std::string OutputRecorder::text() const {
  std::lock_guard lock(mutex_);
  return text_;
}

std::vector<OutputRecorder::Batch> OutputRecorder::batches() const {
  std::lock_guard lock(mutex_);
  return batches_;
}

std::uint64_t OutputRecorder::cycle_of(std::size_t index) const {
  std::lock_guard lock(mutex_);
  for (const Batch& batch : batches_) {
    if (index < batch.bytes.size()) return batch.cycle;
    index -= batch.bytes.size();
  }
  throw std::out_of_range("OutputRecorder::cycle_of: no such byte");
}

void OutputRecorder::clear() {
  std::lock_guard lock(mutex_);
  batches_.clear();
  text_.clear();
}

bool OutputRecorder::wait_for(std::string_view needle, std::chrono::milliseconds timeout, std::size_t count) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return count_occurrences(text_, needle) >= count; });
}

bool OutputRecorder::wait_for_size(std::size_t size, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return text_.size() >= size; });
}

bool run_until(const std::function<void(SimDuration)>& advance, const std::function<bool()>& done,
               SimDuration limit, SimDuration step) {
  for (SimDuration elapsed{}; elapsed < limit && !done(); elapsed += step) advance(step);
  return done();
}

std::string read_until(VirtualUno& uno, std::string_view needle, std::chrono::milliseconds timeout) {
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::uint8_t buffer[256];
  while (text.find(needle) == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    const std::size_t got = uno.read(buffer, left);
    text.append(reinterpret_cast<const char*>(buffer), got);
  }
  return text;
}

// --- PtyClient ----------------------------------------------------------------------------------------

PtyClient::PtyClient(const std::string& path) { fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK); }

PtyClient::~PtyClient() {
  if (fd_ >= 0) ::close(fd_);
}

void PtyClient::write(std::string_view text) {
  while (!text.empty()) {
    const ssize_t put = ::write(fd_, text.data(), text.size());
    if (put < 0) {
      if (errno == EAGAIN || errno == EINTR) {
        pollfd descriptor{fd_, POLLOUT, 0};
        ::poll(&descriptor, 1, 100);
        continue;
      }
      throw std::runtime_error("PtyClient::write failed");
    }
    text.remove_prefix(static_cast<std::size_t>(put));
  }
}

std::string PtyClient::read_until(std::string_view needle, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (pending_.find(needle) == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd descriptor{fd_, POLLIN, 0};
    if (::poll(&descriptor, 1, static_cast<int>(left.count())) <= 0) continue;
    char buffer[512];
    const ssize_t got = ::read(fd_, buffer, sizeof buffer);
    if (got > 0) pending_.append(buffer, static_cast<std::size_t>(got));
  }
  std::string result;
  result.swap(pending_);
  return result;
}

bool PtyClient::hung_up(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    char buffer[256];
    const ssize_t got = ::read(fd_, buffer, sizeof buffer);
    if (got == 0 || (got < 0 && errno == EIO)) return true;
    if (got > 0) continue;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    pollfd descriptor{fd_, POLLIN, 0};
    ::poll(&descriptor, 1, 10);
  }
}

// --- ChildProcess ---------------------------------------------------------------------------------------

ChildProcess::ChildProcess(const std::vector<std::string>& argv) {
  int out[2];
  int err[2];
  if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  if (::pipe2(err, O_CLOEXEC) != 0) {
    ::close(out[0]);
    ::close(out[1]);
    throw std::runtime_error("pipe2 failed");
  }
  std::vector<char*> args;
  for (const auto& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  pid_ = ::fork();
  if (pid_ == 0) {
    ::dup2(out[1], STDOUT_FILENO);
    ::dup2(err[1], STDERR_FILENO);
    // A test runner may block signals; the child must see SIGINT/SIGTERM as a user would send them.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(out[1]);
  ::close(err[1]);
  out_ = out[0];
  err_ = err[0];
  if (pid_ < 0) throw std::runtime_error("fork failed");
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !status_) {
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }
  if (out_ >= 0) ::close(out_);
  if (err_ >= 0) ::close(err_);
}

std::optional<std::string> ChildProcess::read_line(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto newline = out_buffer_.find('\n');
    if (newline != std::string::npos) {
      std::string line = out_buffer_.substr(0, newline);
      out_buffer_.erase(0, newline + 1);
      return line;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    pollfd descriptor{out_, POLLIN, 0};
    if (::poll(&descriptor, 1, static_cast<int>(left.count())) <= 0) continue;
    char buffer[256];
    const ssize_t got = ::read(out_, buffer, sizeof buffer);
    if (got <= 0) return std::nullopt;
    out_buffer_.append(buffer, static_cast<std::size_t>(got));
  }
}

void ChildProcess::signal(int number) {
  if (pid_ > 0 && !status_) ::kill(pid_, number);
}

std::optional<int> ChildProcess::wait(std::chrono::milliseconds timeout) {
  if (status_) return status_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t done = ::waitpid(pid_, &status, WNOHANG);
    if (done == pid_) {
      status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      drain_stderr(true);
      return status_;
    }
    drain_stderr(false);
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(10ms);
  }
}

std::string ChildProcess::error_output() {
  drain_stderr(false);
  return err_buffer_;
}

void ChildProcess::drain_stderr(bool block) {
  for (;;) {
    pollfd descriptor{err_, POLLIN, 0};
    if (::poll(&descriptor, 1, block ? 100 : 0) <= 0) return;
    char buffer[512];
    const ssize_t got = ::read(err_, buffer, sizeof buffer);
    if (got <= 0) return;
    err_buffer_.append(buffer, static_cast<std::size_t>(got));
  }
}

}  // namespace tether::transports::test
