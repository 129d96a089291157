// Internal: a pseudo-terminal bridging a virtual Uno's UART to serial programs (picocom, pyserial, ...).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <system_error>

namespace tether::transports::detail {

/// A pty pair kept raw from the start: the slave is configured with cfmakeraw() before its path is
/// handed out, and the harness keeps its own slave descriptor open, so clients may open and close the
/// port as often as they like (the master never sees a hang-up) and output written before a client
/// opens it waits in the pty. Both descriptors are closed by the destructor. No files are created.
class Pty {
 public:
  /// nullptr and `error` set on failure.
  static std::unique_ptr<Pty> open(std::uint32_t baud, std::error_code& error);
  ~Pty();
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;

  const std::string& path() const { return path_; }
  int master_fd() const { return master_; }

  /// Appends what clients wrote (non-blocking) to `out`, up to `limit` bytes. Returns the count.
  std::size_t read_input(std::deque<std::uint8_t>& out, std::size_t limit);
  /// Sends bytes to clients; what the pty cannot take now is kept and retried by `flush()`, up to
  /// `kPendingLimit` bytes (older bytes beyond that are discarded and counted).
  void write_output(const std::uint8_t* data, std::size_t size);
  void flush();
  std::uint64_t discarded() const { return discarded_; }
  /// Starts noticing clients opening the slave (inotify IN_OPEN on its path; the harness's own descriptor
  /// was opened before). Returns false with `error` set when inotify is unavailable.
  bool watch_opens(std::error_code& error);
  /// True when a client opened the slave since the last call (non-blocking; false without watch_opens()).
  bool client_opened();

  static constexpr std::size_t kPendingLimit = std::size_t{1} << 20;

 private:
  Pty() = default;
  int master_ = -1;
  int slave_ = -1;
  int inotify_ = -1;
  std::string path_;
  std::deque<std::uint8_t> pending_;
  std::uint64_t discarded_ = 0;
};

}  // namespace tether::transports::detail
