// A test-only codec, "line-echo": the host sends a line of text, the device answers with the same line. It
// exists to prove that a codec is one folder plus one row of the codec table: this folder holds its wire
// format, its client and its row (devices columns and the `tether` command's), registered by test code only
// (`register_line_echo`), never shipped in the `tether` program.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include <boost/system/error_code.hpp>

#include "tether/core/counters.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/transports/byte_stream.hpp"

namespace tether::line_echo {

/// Longest line either side sends, newline excluded; longer input is an error, never a growing buffer.
inline constexpr std::size_t kMaxLine = 120;

/// The device's options (`"options": {"timeout_ms": 500}`).
struct Options {
  std::uint32_t timeout_ms = 1000;  ///< how long a call waits for the echo
};

/// Incremental decoder: bytes in, whole lines out (without '\n'; a '\r' before it is dropped).
class LineDecoder {
 public:
  /// What one byte completed.
  enum class Event { none, line, oversize };
  /// Feeds one byte; on `line` the text is in `line()` until the next call.
  Event feed(std::uint8_t byte);
  const std::string& line() const { return line_; }

 private:
  std::string pending_;
  std::string line_;
  bool skipping_ = false;  // the rest of an oversize line
};

/// The host's client: one blocking call at a time.
class Client final {
 public:
  Client(std::shared_ptr<transports::ByteStream> stream, Options options);
  /// Sends `text` (one line, at most `kMaxLine` characters, no '\n') and returns the line that came back;
  /// `error` set on a bad line (invalid_argument), no answer in time (timed_out) or a failed link.
  std::string call(std::string_view text, boost::system::error_code& error);
  LinkCounters counters() const;
  /// Closes the stream (what the rover calls when it closes).
  void close();

 private:
  std::shared_ptr<transports::ByteStream> stream_;
  Options options_;
  mutable std::mutex mutex_;
  LineDecoder decoder_;
  LinkCounters counters_;
};

/// The codec's row of the table: `devices::CodecRow` and the `tether` command's `cli::CodecCommands`.
/// Registers "line-echo" once (later calls do nothing) and returns its value.
devices::Codec register_line_echo();

}  // namespace tether::line_echo
