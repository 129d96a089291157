/// @file compat_device.hpp
/// The device side of the DEPLOYED proxy variant (compatibility mode): what the existing rocketry firmware
/// does on the wire, on Tether's drivers. Schema codecs/proxy/proto/rocketry.proto (package RocketryProto).
///
/// ## Framing (57600 8N1 in the image)
/// Host to device `00 ‖ COBS(ArduinoIn) ‖ 00`, device to host `COBS(ArduinoOut) ‖ 00`: no CRC
/// (`Integrity::none`), no message ids, no acks, no ping, no failsafe. The leading 00 the host sends is
/// an empty frame, ignored; frames without it are accepted too. Bad COBS and frames over kMaxPayload (64)
/// bytes are dropped and counted (`counters().link`), without a message (the deployed firmware has none).
///
/// ## Behaviour (the deployed firmware's, as specified)
///   1. `begin` (end of setup) sends `EventMessage{RESET}` (type 0, data 0: `02 0a 01 00` on the wire).
///   2. Before acting on an init or a control it sends `EventMessage{type, data = pin}` with type
///      SERVO_INIT, SERVO_CONTROL, DIGITAL_INIT or DIGITAL_CONTROL; then it acts:
///      - ServoInit{pin, safePosition}: servo on D9/D10, driven at once to safePosition.
///      - DigitalInit{pin, safeState}: digital output on 2..19, driven at once to safeState (uint32:
///        non-zero = high).
///      - ServoControl{pin, position} / DigitalControl{pin, activate}: drives an initialised pin.
///      Positions are DEGREES 0..180 as in the primary mode (clamped; 1000..2000 us pulses every 20 ms):
///      the deployed schema does not say, and the deployed host sends degrees-range values.
///   3. A control of a pin that is not initialised (as that kind):
///      `ErrorMessage{PIN_NOT_INITIALIZED, data = pin}` (e.g. `07 12 04 08 02 10 0d 00` for pin 13).
///      Tether's choice for an init this board cannot do (a pin that does not exist, such as 1823; D0/D1;
///      a servo on a pin other than D9/D10): the same `ErrorMessage{PIN_NOT_INITIALIZED, data = pin}`,
///      after the init's EventMessage -- the pin stays uninitialised, which is what the deployed host
///      needs to know, and the deployed schema has no better code. `data` is the pin as int32 (a pin
///      above 2^31 shows negative).
///   4. Reset{}: the restart hook (flush the UART, watchdog reset), nothing sent first; the next boot
///      sends EventMessage{RESET}.
///   5. DCMotorInit, DCMotorControl, StepperMotorControl (not driven by this image) and unknown oneof
///      cases: `ErrorMessage{UNKNOWN_MESSAGE, data = the oneof field number}` (0 for an unknown one).
///   6. A payload that is not an ArduinoIn: `ErrorMessage{DECODE_ERROR}`.
///   7. Every kStatePeriodMs (50 ms) from `begin`: `ServoState{pin, position}` or `DigitalState{pin,
///      activated}` for each initialised pin, in pin order (e.g. `05 22 02 08 08 00` for D8 low). The
///      deployed host considers a pin lost when its state is not refreshed for 5 s.
///
/// Memory (ATmega328P, measured): 156 bytes of static RAM plus the OutputTable (60). No heap.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/proxy/device/outputs.hpp"
#include "tether/proxy/frame.hpp"

namespace tether {
namespace proxy {
namespace device {

/// Diagnostics of a compatibility-mode device. Counters only grow (wrap at 2^32). Plain data.
struct CompatDeviceCounters {
  LinkCounters link;           ///< frames_ok, framing_errors, oversize_frames, resyncs.
  uint32_t decode_errors = 0;  ///< Frames whose payload was not an ArduinoIn (DECODE_ERROR sent).
  uint32_t executed = 0;       ///< Messages decoded and handled.
  uint32_t refused = 0;        ///< Messages answered with PIN_NOT_INITIALIZED or UNKNOWN_MESSAGE.
  uint32_t send_failures = 0;  ///< Messages that did not encode (a bug: never expected).
};

/// A deployed-variant proxy device. Not copyable; main loop only.
class CompatDevice {
 public:
  /// Period of the ServoState/DigitalState stream.
  static constexpr Duration kStatePeriodMs = 50;
  /// Largest ArduinoIn payload accepted (its bound is 38 bytes).
  static constexpr size_t kMaxPayload = 64;

  /// Device driving `outputs`, sending through `sink`, restarting through `restart(restart_context)`
  /// (null: Reset ignored, for tests). `outputs` must outlive it.
  CompatDevice(OutputTable& outputs, FrameSink sink, RestartFunction restart = nullptr,
               void* restart_context = nullptr);
  CompatDevice(const CompatDevice&) = delete;
  CompatDevice& operator=(const CompatDevice&) = delete;

  /// End of setup: sends EventMessage{RESET}, starts the state stream's clock at `now`.
  void begin(Millis now);
  /// Handles one received byte; a completed frame is handled at once.
  void handle_byte(uint8_t byte);
  /// Streams the pin states when due. Call every loop pass.
  void poll(Millis now);
  /// Sends ServoState/DigitalState for every initialised pin now (what `poll` does every 50 ms).
  void send_states();

  /// Diagnostics.
  const CompatDeviceCounters& counters() const { return counters_; }

 private:
  void handle_payload(ByteView payload);
  bool send(const void* out_message);
  void send_event(uint8_t type, uint32_t pin);
  void send_error(uint8_t type, int32_t data);

  OutputTable* outputs_;
  FrameSink sink_;
  RestartFunction restart_;
  void* restart_context_;
  CompatDeviceCounters counters_;  // before the decoder, which counts into it
  FrameDecoder<kMaxPayload> decoder_;
  Deadline next_states_;
};

}  // namespace device
}  // namespace proxy
}  // namespace tether
