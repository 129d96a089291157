/// @file proxy_device.hpp
/// The device side of the proxy protocol, primary mode: `COBS(crc16 ‖ ArduinoIn) ‖ 00` in,
/// `COBS(crc16 ‖ ArduinoOut) ‖ 00` out (schema codecs/proxy/proto/tether_proxy.proto, nanopb, no heap).
///
/// ## Use (see firmware/proxy/image/proxy.cpp)
///
///     OutputTable outputs;
///     ProxyDevice device(outputs, FrameSink{write_to_uart, nullptr}, flush_and_reset, nullptr);
///     device.begin(boot_session_id(), millis());        // end of setup: sends ResetEvent
///     for (;;) { consume(device.handle_bytes(received_bytes, millis())); device.poll(millis()); idle(); }
///
/// ## Wire behaviour
///   1. Boot: `begin` sends `ResetEvent{sessionId}`, preceded by one 0x00 (flushes whatever half frame the
///      host may hold from before the reset). Every other frame is sent without a leading 0x00.
///   2. Frames: empty frames are ignored; bad COBS, CRC mismatches and frames over kMaxPayload (64) bytes
///      are dropped and counted (`counters().link`). A frame not complete kPartialFrameMs (100 ms) after
///      its first byte is dropped and counted (partial_timeouts); the decoder then takes the next byte as
///      the start of a new frame. Drops are reported together, not per frame: at each ArduinoInfo tick,
///      if any count changed, `Error{WARNING, "dropped: crc N cobs N long N stall N"}` (totals since boot).
///   3. A payload that is not an ArduinoIn: `Error{WARNING, "decode error"}` (no ack: no id to ack).
///   4. Every decoded ArduinoIn is acknowledged with `Ack{messageId}`, AFTER the messages it causes (so the
///      ack closes its reply: everything a message caused has arrived when its ack arrives).
///   5. A message whose messageId AND payload CRC-16 match one of the last 8 executed
///      (`DuplicateFilter<uint32_t, 8, 0>`) is a re-send: acked again, nothing else (not executed, no
///      PinState, no Error). The same id with different bytes is a new message (a new host session).
///   6. Execution, per oneof:
///      - Ping: feeds the failsafe watchdog (nothing else does).
///      - ServoInit / DigitalInit: drives the pin to its safe value (outputs.hpp), then `PinState{pin,
///        value, failsafe=false}`. ServoControl / DigitalControl: drives it, then `PinState`. Servo values
///        are degrees 0..180, digital values 0/1.
///        Refusals, each `Error{WARNING, text}` naming the pin, nothing driven:
///          "servo on pin N: D9/D10 only", "pin N is the UART" (0/1), "pin N does not exist" (>= 20),
///          "pin N not initialised", "pin N is not a servo", "pin N is not digital",
///          "pin N: position P not in 0..180" (a ServoInit's safePosition or a ServoControl's position).
///      - Reset: the Ack is sent, then the restart hook (flush the UART, watchdog reset). The next boot
///        sends ResetEvent with a new sessionId.
///      - PingFailsafeReset: clears the sticky pingFailsafeTriggered flag.
///      - None of those (a newer host's message, or only a messageId): `Error{WARNING, "unknown message"}`.
///   7. Failsafe: kPingSilenceMs (10 s) after `begin` or the last Ping, at the first poll at or past the
///      limit (FailsafeWatchdog): every initialised pin goes to its safe value, pingFailsafeTriggered is
///      set, and the device sends `Error{WARNING, "ping failsafe"}` then `PinState{pin, safe value,
///      failsafe=true}` for each initialised pin (in pin order). It fires once per silence: again only
///      after a Ping and another 10 s without one. Controls received afterwards are executed (a host that
///      sends them is alive; the failsafe was an event, not a lock). The flag stays set until
///      PingFailsafeReset, also across Pings.
///   8. `ArduinoInfo{sessionId, pingFailsafeTriggered}` every kInfoPeriodMs (5 s) from `begin` (first at
///      5 s). When the failsafe and an ArduinoInfo fall due in the same poll, the failsafe goes first, so
///      that ArduinoInfo already shows the flag.
///
/// ## Memory (ATmega328P, measured): 245 bytes of static RAM per device (counters 64, frame decoder ~72,
/// duplicate filter 51, watchdog, deadlines and state ~58), plus the OutputTable (54). No heap. Stack:
/// sending a message needs ~450 bytes at the peak (nanopb's encoder ~250, the payload and frame buffers of
/// io.hpp ~160, an ArduinoOut ~55); the `proxy` image peaks at ~615 bytes, interrupts included.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/session/duplicate_filter.hpp"
#include "tether/core/session/failsafe_watchdog.hpp"
#include "tether/core/session/partial_frame_deadline.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/proxy/device/outputs.hpp"
#include "tether/proxy/device/text.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"

namespace tether {
namespace proxy {
namespace device {

/// Diagnostics of a primary-mode device. Counters only grow (wrap at 2^32). Plain data.
struct ProxyDeviceCounters {
  /// Frame layer and session engine: frames_ok, crc_errors, framing_errors, oversize_frames, resyncs,
  /// partial_timeouts, duplicates (re-sends acked, not executed), failsafes.
  LinkCounters link;
  uint32_t decode_errors = 0;  ///< Checked frames whose payload was not an ArduinoIn.
  uint32_t executed = 0;       ///< Messages executed (each messageId at most once).
  uint32_t refused = 0;        ///< Executed messages answered with an Error (bad pin, unknown message).
  uint32_t send_failures = 0;  ///< Messages that did not encode (a bug: never expected).
};

/// A primary-mode proxy device. Not copyable; main loop only (never from an interrupt).
class ProxyDevice {
 public:
  /// Silence (no Ping) that triggers the failsafe.
  static constexpr Duration kPingSilenceMs = 10000;
  /// Period of ArduinoInfo.
  static constexpr Duration kInfoPeriodMs = 5000;
  /// Time a frame may take from its first byte to its delimiter (115200 baud: a full frame takes ~6 ms).
  static constexpr Duration kPartialFrameMs = 100;
  /// Largest ArduinoIn payload accepted (ArduinoIn's bound is 25 bytes: room for unknown fields).
  static constexpr size_t kMaxPayload = 64;
  /// Executed messages remembered for duplicate detection (>= the host's messages in flight).
  static constexpr uint8_t kDuplicateDepth = 8;

  /// Device driving `outputs`, sending through `sink`, restarting through `restart(restart_context)`
  /// (null: Reset is acked and ignored, for tests). `outputs` must outlive it.
  /// constexpr: a device with static storage is constant-initialised (its bytes come with .data; no
  /// constructor runs at startup: the image's was 328 B of code storing zeros into .bss).
  constexpr ProxyDevice(OutputTable& outputs, FrameSink sink, RestartFunction restart = nullptr,
                        void* restart_context = nullptr)
      : outputs_(&outputs),
        sink_(sink),
        restart_(restart),
        restart_context_(restart_context),
        counters_{},
        decoder_(Integrity::crc16, counters_.link),
        partial_(kPartialFrameMs, counters_.link),
        executed_(counters_.link),
        watchdog_(kPingSilenceMs, counters_.link, &ProxyDevice::on_failsafe, this) {}
  ProxyDevice(const ProxyDevice&) = delete;
  ProxyDevice& operator=(const ProxyDevice&) = delete;

  /// End of setup: remembers `session_id`, starts the failsafe and info clocks at `now`, sends ResetEvent.
  void begin(uint32_t session_id, Millis now);
  /// Handles one received byte at `now`; a completed frame is executed at once.
  void handle_byte(uint8_t byte, Millis now);
  /// Handles received bytes at `now` up to and including the first one that completes a frame (executed
  /// at once) or drops one; returns how many it used: call again with the rest. The same as handing them
  /// to `handle_byte` one by one, but a run of data bytes goes through the decoder's tight loop; the image
  /// hands it what its UART ring holds in place (`Uart0::peek`), with no copy.
  size_t handle_bytes(ByteView bytes, Millis now) { return handle_bytes(bytes.data(), bytes.size(), now); }
  /// The same on the `size` bytes at `data` (what the view's callers compile to: a view built for the call
  /// went through the stack on the AVR).
  size_t handle_bytes(const uint8_t* data, size_t size, Millis now);
  /// Handles time: failsafe, ArduinoInfo, drop reports, partial-frame deadline. Call every loop pass
  /// (at least every few ms: the failsafe fires at the first poll past its limit).
  void poll(Millis now);

  /// This boot's sessionId.
  uint32_t session_id() const { return session_id_; }
  /// The sticky pingFailsafeTriggered flag.
  bool failsafe_triggered() const { return watchdog_.triggered(); }
  /// Diagnostics.
  const ProxyDeviceCounters& counters() const { return counters_; }

 private:
  static void on_failsafe(void* self, Millis now);
  void track_frame(bool was_in_frame, Millis now);  // the partial-frame deadline after a feed
  void handle_payload(ByteView payload, uint16_t fingerprint, Millis now);
  bool send(const void* out_message, bool leading_delimiter = false);
  void send_word(pb_size_t which, uint32_t word, bool flag);  // Ack, ArduinoInfo or ResetEvent
  void send_error(FlashText text);
  void send_pin_state(uint8_t pin, bool failsafe);
  void report_pin_result(PinResult result, uint32_t pin, bool servo, int32_t value);
  void report_drops();

  OutputTable* outputs_;
  FrameSink sink_;
  RestartFunction restart_;
  void* restart_context_;
  ProxyDeviceCounters counters_;  // before the members that count into it
  Decoder<kMaxPayload> decoder_;
  session::PartialFrameDeadline partial_;
  session::DuplicateFilter<uint32_t, kDuplicateDepth, 0> executed_;
  session::FailsafeWatchdog watchdog_;
  Deadline next_info_;
  uint32_t session_id_ = 0;
  uint32_t reported_drops_ = 0;  // sum of the drop counters at the last report
};

}  // namespace device
}  // namespace proxy
}  // namespace tether
