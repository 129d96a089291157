// A scripted Romi device for client tests: reads requests from its end of a ByteStream (in-memory pair or
// pty master) with the codec's decoder and lets the test script the answers, byte for byte.
#pragma once

#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "tether/romi/envelope_decoder.hpp"
#include "tether/transports/byte_stream.hpp"

namespace tether::romi::testing {

/// One frame the device received.
struct DeviceRequest {
  std::string frame;    ///< raw bytes from '#' through '\n'
  std::string payload;  ///< opcode + arguments (empty for a damaged frame)
  bool manual = false;  ///< `xxxx` metadata
  std::uint8_t id = 0;  ///< the id (0 for manual frames)
  char opcode = '_';    ///< first payload character
  ErrorCode error = ErrorCode::no_error;  ///< decoder error of a damaged frame
  int repeat = 1;       ///< how many times this exact frame has been received so far (1 the first time)
};

/// Scripted device; create with `start`, always `close` (or drop) it.
class FakeDevice : public std::enable_shared_from_this<FakeDevice> {
 public:
  /// Called on the device's strand for every frame received (good or damaged).
  using Script = std::function<void(const DeviceRequest& request, FakeDevice& device)>;

  /// Device reading from `end` at once.
  static std::shared_ptr<FakeDevice> start(std::shared_ptr<transports::ByteStream> end);
  ~FakeDevice();
  FakeDevice(std::shared_ptr<transports::ByteStream> end, int);  // for make_shared

  /// Sets the script (any thread, before the requests it should see).
  void on_request(Script script);
  /// Writes `bytes` now (in order with every other send).
  void send(std::string bytes);
  /// Writes `bytes` after `delay`.
  void send_after(std::chrono::milliseconds delay, std::string bytes);
  /// Closes the stream and cancels delayed sends.
  void close();

  /// Every request so far (snapshot).
  std::vector<DeviceRequest> requests() const;
  /// Every byte received so far.
  std::string received() const;
  /// Waits until at least `count` requests arrived; false after `timeout`.
  bool wait_for_requests(std::size_t count, std::chrono::milliseconds timeout) const;

  /// A response frame: `#` opcode body `:` id crc CRLF (':' in the body become '-').
  static std::string response(char opcode, std::string_view body, std::uint8_t id);
  /// A log frame `#!text:xxxx\r\n`.
  static std::string log(std::string_view text);
  /// `frame` with one CRC digit changed: the host decoder sees a CRC mismatch.
  static std::string corrupt_crc(std::string frame);

 private:
  void read();
  void on_bytes(const std::uint8_t* data, std::size_t size);
  void write_next();

  std::shared_ptr<transports::ByteStream> end_;
  boost::asio::strand<boost::asio::any_io_executor> strand_;
  LinkCounters counters_;
  EnvelopeDecoder<kHostDecoderCapacity> decoder_{counters_};
  std::string frame_;  // bytes of the frame in progress
  std::map<std::string, int> seen_;
  std::deque<std::shared_ptr<std::string>> writes_;
  bool writing_ = false;
  std::vector<std::shared_ptr<boost::asio::steady_timer>> timers_;
  std::shared_ptr<std::array<std::uint8_t, 512>> buffer_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  Script script_;
  std::vector<DeviceRequest> requests_;
  std::string received_;
};

}  // namespace tether::romi::testing
