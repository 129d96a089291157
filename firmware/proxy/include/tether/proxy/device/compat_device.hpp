/// @file compat_device.hpp
/// The device side of the DEPLOYED proxy variant (compatibility mode): what the existing rocketry firmware
/// does on the wire and on the pins, on Tether's drivers. Schema codecs/proxy/proto/rocketry.proto
/// (package RocketryProto). Deliberate differences from the deployed firmware: docs/proxy.md,
/// "Compatibility table".
///
/// ## Framing (57600 8N1 in the image)
/// Host to device `00 ‖ COBS(ArduinoIn) ‖ 00`, device to host `COBS(ArduinoOut) ‖ 00`: no CRC
/// (`Integrity::none`), no message ids, no acks, no ping, no failsafe. The leading 00 the host sends is
/// an empty frame, ignored; frames without it are accepted too. Bad COBS and frames over kMaxPayload (64)
/// bytes are dropped and counted (`counters().link`), without a message (the deployed firmware has none).
///
/// ## Behaviour (the deployed firmware's, uORocketry e5f01c9, measured on a simulated Uno unless an item says
/// it is read from its source; "Tether:" marks where this device differs)
///   1. `begin` (end of setup) sends `EventMessage{RESET}` (`02 0a 01 00` on the wire).
///   2. ServoInit{pin, safePosition}: the pin becomes a servo at 1500 us (Arduino `Servo::attach`), its
///      reported position is -1 until the first control, safePosition is NOT applied (the deployed
///      firmware stores it and never uses it); then `EventMessage{SERVO_INIT, pin}`. Any pin can carry
///      a servo (interrupt-driven pulses, up to 12 servos). A ServoInit of a pin that already is a servo
///      is ignored silently (nothing sent, nothing changes).
///   3. DigitalInit{pin, safeState}: the pin becomes an output at safeState (non-zero = high; measured: D7
///      went high on both) and reports it; then `EventMessage{DIGITAL_INIT, pin}`. Tether: the level is
///      written before the direction (the deployed firmware's pinMode-then-digitalWrite drives the pin low
///      in between). Again ignored silently for a pin already digital. D0/D1 are accepted (state kept and
///      reported) but stay the UART's on the wire, as on the chip, where the USART overrides the port.
///   4. ServoControl{pin, position}: `EventMessage{SERVO_CONTROL, pin}`, then `Servo::write(position)`
///      semantics (pins.hpp `arduino_servo_pulse_us`: below 544 an angle clamped to 0..180 -> 544..2400
///      us, from 544 on microseconds up to 2400); the reported position is the value written (the
///      position as a 16-bit int, as the deployed `int`), unclamped. DigitalControl{pin, activate}:
///      `EventMessage{DIGITAL_CONTROL, pin}`, then the level.
///   5. A control of a pin (or DC motor) that is not initialised as that kind: only
///      `ErrorMessage{PIN_NOT_INITIALIZED, data = pin}` (`07 12 04 08 02 10 0d 00` for pin 13), no event.
///   6. DCMotorInit{limitSwitchMinPin, limitSwitchMaxPin, potentiometerPin, motorForwardPin,
///      motorReversePin, motorPower}: up to kMaxDcMotors motors keyed by (forward, reverse); limit switches
///      become inputs, the potentiometer an input with pull-up, both motor pins outputs at low; then
///      `EventMessage{DC_MOTOR_INIT, forward}`. Again ignored silently for a known motor.
///      DCMotorControl{pinForward, pinReverse, position}: `EventMessage{DC_MOTOR_CONTROL, forward}`, then
///      the target is `position` (ADC counts of the potentiometer): forward (forward pin at motorPower,
///      reverse low) when the last reading is below it, reverse when above, stop when equal. Every `poll`
///      reads each motor's potentiometer and limit switches and stops a moving motor when the switch in
///      its direction closes (reads high) or its reading passed the target.
///   7. StepperMotorControl, and any other oneof case: `ErrorMessage{UNKNOWN_MESSAGE, data 0}`.
///   8. Reset{}: the restart hook (flush the UART, watchdog reset), nothing sent first. Tether: a real
///      reset, every pin a floating input until setup; the deployed firmware jumps to address 0, so its
///      outputs stay driven (measured: D7 stayed high, D9/D5/D6 stayed outputs, the servo pulses stopped).
///   9. A payload that is not an ArduinoIn: `ErrorMessage{DECODE_ERROR}` (`02 12 01 00`).
///  10. The state stream: `ServoState{pin, position}` for each servo, `DigitalState{pin, activated}` for
///      each digital output (pin order), `DCMotorState{forward, reverse, position, direction 1/0/-1,
///      minLimitSwitch, maxLimitSwitch}` for each motor (init order), then `LoadCellState{value}` when the
///      HX711 has a conversion ready (`02 3a 01 00` for 0, what an unwired input reads in the simulator).
///      Tether: every kStatePeriodMs (50.0 ms) from `begin`, whatever it sends. The deployed firmware
///      sends when `millis() - last > 50`, `last` taken after its sends: measured 56.0 ms idle, 57.1 ms
///      with a servo and a digital output.
///  11. The HX711: the deployed firmware clocks PD_SCK on D13 and reads DOUT on D12 (its PORTB/PINB bits,
///      read from its source; measured: 25-pulse bursts on D13 every period, A5 never toggles). Tether:
///      the same pins (kLoadCellDataPin, kLoadCellClockPin), D13 an output from `begin` on, the ready
///      check on D12 (the deployed firmware's reads A4), the 24-bit conversion sign-extended.
/// Tether: inits it cannot do -- a pin that does not exist (20 and up), D12/D13 (the load cell's: a
/// DigitalInit 13 too), a 13th servo, a third DC motor, a potentiometer off A0..A5 -- answer
/// `ErrorMessage{PIN_NOT_INITIALIZED, data = pin}` (a DC motor: its forward pin) and change nothing;
/// `motorPower` above 255 drives as 255.
///
/// Memory (ATmega328P): about 160 bytes of static RAM with the decoder. No heap.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/proxy/device/pins.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"

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
  /// Period of the state stream, exactly (the deployed firmware's is 56-57 ms: item 10 above).
  static constexpr Duration kStatePeriodMs = 50;
  /// Largest ArduinoIn payload accepted (its bound is 38 bytes).
  static constexpr size_t kMaxPayload = 64;
  /// DC motors at most (the deployed firmware's table size).
  static constexpr uint8_t kMaxDcMotors = 2;
  /// Reported position of a servo before its first control.
  static constexpr int16_t kUnsetPosition = -1;

  /// Device sending through `sink`, restarting through `restart(restart_context)` (null: Reset ignored,
  /// for tests).
  explicit CompatDevice(FrameSink sink, RestartFunction restart = nullptr, void* restart_context = nullptr);
  CompatDevice(const CompatDevice&) = delete;
  CompatDevice& operator=(const CompatDevice&) = delete;

  /// End of setup: prepares the load cell (D12/D13), sends EventMessage{RESET}, starts the state stream's
  /// clock.
  void begin(Millis now);
  /// Handles one received byte; a completed frame is handled at once.
  void handle_byte(uint8_t byte);
  /// Handles received bytes up to and including the first one that completes a frame (handled at once) or
  /// drops one; returns how many it used: call again with the rest. The same as `handle_byte` on each, but
  /// a run of data bytes goes through the decoder's tight loop.
  size_t handle_bytes(ByteView bytes);
  /// Runs the DC motors' control loop and streams the states when due. Call every loop pass.
  void poll(Millis now);
  /// Sends every state now (what `poll` does every 50 ms).
  void send_states();

  /// True when `pin` is a servo.
  bool is_servo(uint32_t pin) const { return pin < kPinCount && (servos_ & bit(pin)) != 0; }
  /// Reported position of servo `pin` (kUnsetPosition before its first control).
  int16_t servo_position(uint32_t pin) const { return pin < kPinCount ? servo_position_[pin] : kUnsetPosition; }
  /// True when `pin` is a digital output.
  bool is_digital(uint32_t pin) const { return pin < kPinCount && (digitals_ & bit(pin)) != 0; }
  /// Level of digital output `pin`.
  bool digital_level(uint32_t pin) const { return pin < kPinCount && (levels_ & bit(pin)) != 0; }

  /// Diagnostics.
  const CompatDeviceCounters& counters() const { return counters_; }

 private:
  struct DcMotor {
    uint8_t forward;
    uint8_t reverse;
    uint8_t potentiometer;  // ADC channel
    uint8_t limit_min;
    uint8_t limit_max;
    uint8_t power;
    int8_t direction;  // 1 forward, 0 stopped, -1 reverse
    bool active;
    bool min_limit;
    bool max_limit;
    int32_t target;
    int16_t position;  // last potentiometer reading
  };

  static uint32_t bit(uint32_t pin) { return static_cast<uint32_t>(1) << pin; }
  void handle_payload(ByteView payload);
  void init_servo(uint32_t pin);
  void control_servo(uint32_t pin, int32_t position);
  void init_digital(uint32_t pin, bool safe_high);
  void control_digital(uint32_t pin, bool high);
  void set_level(uint32_t pin, bool high);
  void init_dc_motor(const void* init);
  void control_dc_motor(uint32_t forward, uint32_t reverse, int32_t position);
  DcMotor* find_dc_motor(uint32_t forward, uint32_t reverse);
  void drive_dc_motor(DcMotor& motor, int8_t direction);
  void run_dc_motors();
  bool send(const void* out_message);
  void send_event(uint8_t type, uint32_t pin);
  void send_error(uint8_t type, int32_t data);
  void refuse_pin(uint32_t pin);  // ErrorMessage{PIN_NOT_INITIALIZED, pin}, counted

  FrameSink sink_;
  RestartFunction restart_;
  void* restart_context_;
  CompatDeviceCounters counters_;  // before the decoder, which counts into it
  Decoder<kMaxPayload> decoder_;
  Deadline next_states_;
  uint32_t servos_ = 0;    // bit n: pin n is a servo
  uint32_t digitals_ = 0;  // bit n: pin n is a digital output
  uint32_t levels_ = 0;    // bit n: digital output n is high
  int16_t servo_position_[kPinCount];
  DcMotor motors_[kMaxDcMotors];
  uint8_t motor_count_ = 0;
};

}  // namespace device
}  // namespace proxy
}  // namespace tether
