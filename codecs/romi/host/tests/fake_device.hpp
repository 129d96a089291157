// A scripted Romi device for client tests: reads requests from its end of a ByteStream (in-memory pair or
// pty master) with the codec's decoder and lets the test script the answers, byte for byte.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <string_view>
#include <vector>

#include "tether/romi/decoder.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/testing/scripted_peer.hpp"

namespace tether::romi::testing {

/// One frame the device received.
struct DeviceRequest {
  std::string frame;    ///< raw bytes from '#' through '\n'
  std::string payload;  ///< opcode + arguments (empty for a damaged frame)
  bool manual = false;  ///< `xxxx` metadata
  std::uint8_t id = 0;  ///< the id (0 for manual frames)
  char opcode = '_';    ///< first payload character
  Error error = Error::no_error;  ///< decoder error of a damaged frame
  int repeat = 1;       ///< how many times this exact frame has been received so far (1 the first time)
};

/// Scripted device; create with `start`, always `close` (or drop) it. `send`, `send_after`, `close` and
/// `received` come from the shared `transports::testing::ScriptedPeer`.
class FakeDevice : public transports::testing::ScriptedDevice<FakeDevice, DeviceRequest> {
 public:
  /// Called on the device's strand for every frame received (good or damaged).
  using Script = ScriptedDevice::Script;

  /// Device reading from `end` at once.
  static std::shared_ptr<FakeDevice> start(std::shared_ptr<transports::ByteStream> end);
  FakeDevice(std::shared_ptr<transports::ByteStream> end, int);  // for make_shared

  /// Sets the script (any thread, before the requests it should see).
  void on_request(Script script) { set_script(std::move(script)); }

  /// Every request so far (snapshot).
  std::vector<DeviceRequest> requests() const { return records(); }
  /// Waits until at least `count` requests arrived; false after `timeout`.
  bool wait_for_requests(std::size_t count, std::chrono::milliseconds timeout) const;

  /// A response frame: `#` opcode body `:` id crc CRLF (':' in the body become '-').
  static std::string response(char opcode, std::string_view body, std::uint8_t id);
  /// A log frame `#!text:xxxx\r\n`.
  static std::string log(std::string_view text);
  /// `frame` with one CRC digit changed: the host decoder sees a CRC mismatch.
  static std::string corrupt_crc(std::string frame);

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override;

  // Strand only.
  LinkCounters counters_;
  Decoder<kHostDecoderCapacity> decoder_{counters_};
  std::string frame_;  // bytes of the frame in progress
  std::map<std::string, int> seen_;
};

}  // namespace tether::romi::testing
