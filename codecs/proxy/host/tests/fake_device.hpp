// A scripted proxy device for client tests: reads host frames from its end of a ByteStream with the
// codec's frame decoder, decodes them with the mode's schema, and lets the test script the answers,
// byte for byte.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rocketry.pb.h"
#include "tether/client/link_clock.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/testing/scripted_peer.hpp"
#include "tether_proxy.pb.h"

namespace tether::proxy::testing {

/// One frame the device received.
struct DeviceFrame {
  std::string wire;                   ///< the frame's bytes: COBS data and its closing 0x00
  std::string payload;                ///< the checked payload (empty for a damaged frame)
  bool damaged = false;               ///< the decoder dropped it (CRC, COBS, size)
  bool decoded = false;               ///< the payload parsed as the mode's ArduinoIn
  ArduinoIn in;                       ///< primary mode
  RocketryProto::ArduinoIn compat;    ///< compat mode
  int repeat = 1;                     ///< how many times this exact payload arrived so far (1 the first time)
  Millis at = 0;                      ///< arrival, on the device's clock (the test's manual clock)
};

/// Scripted device; create with `start`, always `close` (or drop) it. `send`, `send_after`, `close` and
/// `received` come from the shared `transports::testing::ScriptedPeer`.
class FakeDevice : public transports::testing::ScriptedDevice<FakeDevice, DeviceFrame> {
 public:
  /// Called on the device's strand for every frame received (good or damaged).
  using Script = ScriptedDevice::Script;

  /// Device reading from `end` at once, decoding with `integrity` (crc16: primary, none: compat), stamping
  /// each frame's arrival with `clock` (null: the steady clock), the client's clock in a test.
  static std::shared_ptr<FakeDevice> start(std::shared_ptr<transports::ByteStream> end, Integrity integrity,
                                           Script script = {}, std::shared_ptr<client::LinkClock> clock = nullptr);
  FakeDevice(std::shared_ptr<transports::ByteStream> end, Integrity integrity,
             std::shared_ptr<client::LinkClock> clock);  // for make_shared

  /// Sets the script (any thread, before the frames it should see).
  void on_frame(Script script) { set_script(std::move(script)); }

  /// Every frame so far (snapshot).
  std::vector<DeviceFrame> frames() const { return records(); }
  /// Waits until `predicate(frames())` holds; false after `timeout`.
  bool wait_for(const std::function<bool(const std::vector<DeviceFrame>&)>& predicate,
                std::chrono::milliseconds timeout) const {
    return wait_for_records(predicate, timeout);
  }

  /// A device frame `COBS(crc ‖ pb) ‖ 0x00` (primary) or `COBS(pb) ‖ 0x00` (compat) of raw `payload`.
  static std::string frame_bytes(const std::string& payload, Integrity integrity);
  /// A primary-mode frame of `out`.
  static std::string frame(const ArduinoOut& out);
  /// Primary-mode frames of the common messages.
  static std::string ack(std::uint32_t message_id, bool refused = false);
  static std::string reset_event(std::uint32_t session_id);
  static std::string info(std::uint32_t session_id, bool failsafe);
  static std::string error(const std::string& text, Error::Level level);
  static std::string pin_state(std::uint32_t pin, std::int32_t value, bool failsafe);

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override;

  // Strand only.
  Integrity integrity_;
  std::shared_ptr<client::LinkClock> clock_;
  LinkCounters counters_;
  Decoder<512> decoder_;
  std::string frame_;  // bytes of the frame in progress
  std::map<std::string, int> seen_;
};

/// A well-behaved primary device: acks every intact ArduinoIn (unless `ignore` says so) and answers each
/// Reset with ResetEvent(session), the session starting at `first_session` and growing by one per Reset.
/// `ignore(frame)` returning true drops the frame silently (no ack, no ResetEvent).
FakeDevice::Script standard_device(std::uint32_t first_session = 100,
                                   std::function<bool(const DeviceFrame&)> ignore = {});

/// Hex dump "00 0a ff" of `bytes` (readable assertion failures).
std::string hex(const std::string& bytes);
/// Bytes from a hex dump "00 0a ff".
std::string unhex(const std::string& text);

}  // namespace tether::proxy::testing
