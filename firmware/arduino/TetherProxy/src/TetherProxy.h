/// @file TetherProxy.h
/// The proxy device (firmware/proxy) in an Arduino sketch: an Uno as the host's I/O proxy over any
/// `Stream` (normally `Serial`), with the Arduino core's `millis()` as its clock.
///
///     #include <TetherProxy.h>
///     TetherProxy proxy(Serial);                        // primary mode: COBS + CRC-16, tether.proxy messages
///     void setup() { Serial.begin(115200); proxy.begin(); }
///     void loop() { proxy.poll(); }
///
/// `TetherProxyCompat` is the deployed uORocketry variant (57600 baud, RocketryProto, no CRC/acks/ping).
/// The wire behaviour is the bare-metal images' (tether/proxy/device/proxy_device.hpp, compat_device.hpp):
/// acks, exactly-once per messageId, 10 s ping failsafe, ArduinoInfo every 5 s, Reset through the watchdog.
///
/// Hardware, shared with the images (tether/proxy/device/hardware.hpp): primary-mode servos on D9/D10 use
/// Timer1's hardware PWM, compat-mode servos any pin through a Timer1 interrupt. Timer1 is therefore
/// Tether's: `begin()` takes it back from the Arduino core (whose `init()` starts it for analogWrite on
/// D9/D10), and a sketch must not use the Arduino Servo library or analogWrite on D9/D10 beside it.
/// The primary mode's sessionId uses the last 8 bytes of EEPROM.
#pragma once

#include <Arduino.h>
#include <TetherCore.h>  // first: the Arduino builder finds the TetherCore library by this name

// TetherProxy and a library of `tether generate` each carry the proxy's framing and the nanopb runtime (each
// configured its own way: 64-bit fields on in the generated one): one sketch cannot have both.
#ifdef TETHER_ARDUINO_RPC_LIBRARY
#error "TetherProxy and a library written by tether generate cannot share a sketch: both carry the proxy framing and the nanopb runtime (docs/arduino.md)"
#endif
/// Defined by TetherProxy.h: a `tether generate` library's header refuses to join it (see above).
#define TETHER_ARDUINO_PROXY_LIBRARY 1

#include "TetherArduinoStream.h"
#include "TetherSetArduinoMacrosAside.h"  // Arduino.h's bit, min, max, ... would rewrite Tether's names
#include "tether/proxy/device.hpp"
#include "TetherRestoreArduinoMacros.h"

namespace tether {
namespace arduino {

/// Gives Timer1 to Tether's servo drivers: the Arduino core's init() leaves it running (phase-correct PWM
/// for analogWrite), and the drivers configure the timer only when they find it stopped.
void release_timer1();
/// The bytes waiting in `hardware`'s receive ring (at most one ring's worth per call, so a sender faster
/// than the loop cannot keep it from polling), handed to `feed(ByteView)` in place, in runs: `feed` returns
/// how many of a run it used (a device stops at each completed frame) and is called again with the rest.
/// False, doing nothing, when `hardware` is null or its ring is out of reach (TetherArduinoStream.h): then
/// `drain_copy`.
template <typename Feed>
TETHER_ARDUINO_INLINE bool drain_ring(HardwareSerial* hardware, Feed feed) {
#if TETHER_ARDUINO_SERIAL_RINGS
  if (hardware == nullptr) return false;
  for (uint8_t taken = 0; taken < 64;) {
    const uint8_t* data;
    const uint8_t run = rx_run(*hardware, data);
    if (run == 0) return true;
    const uint8_t used = static_cast<uint8_t>(feed(ByteView(data, run)));
    rx_consume(*hardware, used);
    taken = static_cast<uint8_t>(taken + used);
  }
  return true;
#else
  (void)hardware;
  (void)feed;
  return false;
#endif
}
/// Up to 64 bytes waiting on the port, copied out with one available() (`read_run`: the Stream's virtual
/// calls, or the core's own functions) and handed to `feed` as `drain_ring` does. One run of 64 (a frame
/// of a 32-byte payload is 37): every run handed over costs the device's entry once.
template <typename Feed>
void drain_copy(HardwareSerial* hardware, Stream& stream, Feed feed) {
  uint8_t run[64];
  const uint8_t count = read_run(hardware, stream, run, sizeof run);
  for (uint8_t used = 0; used != count;) {
    used = static_cast<uint8_t>(used + feed(ByteView(run + used, static_cast<size_t>(count - used))));
  }
}
/// Frame sink writing to the `Stream` passed as context (blocks while the TX buffer is full).
void write_frame(void* stream, ByteView frame);
/// Frame sink writing to the `HardwareSerial` passed as context, through its own write() (no virtual calls).
void write_frame_hardware(void* serial, ByteView frame);
/// Restart hook: flushes the `Stream` passed as context (the Reset's ack must leave) and resets through
/// the watchdog.
void restart(void* stream);

}  // namespace arduino
}  // namespace tether

/// Primary mode of the proxy protocol on a `Stream` (115200 8N1 recommended).
class TetherProxy {
 public:
  /// Device talking through `stream`; `begin()` it after `stream.begin(...)`. When `stream` is one of the
  /// core's hardware ports (`Serial` passed as a `Stream&`), its receive ring is read in place as below;
  /// frames still go out through the `Stream` (choosing the ring's writer here would link it into every
  /// sketch on another port: ~500 bytes of flash).
  explicit TetherProxy(Stream& stream)
      : stream_(stream),
        hardware_(tether::arduino::core_serial(&stream)),
        device_(outputs_, tether::proxy::device::FrameSink{tether::arduino::write_frame, &stream},
                tether::arduino::restart, &stream) {}
  /// Device talking through the core's hardware port `serial` (`Serial`): the fast path, its bytes read
  /// and written through the port's own functions.
  explicit TetherProxy(HardwareSerial& serial)
      : stream_(serial),
        hardware_(&serial),
        device_(outputs_, tether::proxy::device::FrameSink{tether::arduino::write_frame_hardware, &serial},
                tether::arduino::restart, static_cast<Stream*>(&serial)) {}
  TetherProxy(const TetherProxy&) = delete;
  TetherProxy& operator=(const TetherProxy&) = delete;

  /// End of setup: derives this boot's sessionId, takes Timer1, sends ResetEvent.
  void begin() {
    const uint32_t session_id = tether::proxy::device::boot_session_id();
    tether::arduino::release_timer1();
    device_.begin(session_id, millis());
  }
  /// Call from loop(): handles received bytes, timers (failsafe, info, partial frames).
  void poll() {
    // One clock read per call, none per byte: the bytes waiting arrived before it.
    const tether::Millis now = millis();
    if (!tether::arduino::drain_ring(hardware_, [this, now](tether::ByteView run) { return device_.handle_bytes(run, now); })) {
      drain_stream(now);
    }
    device_.poll(now);
  }
  /// True once the 10 s ping failsafe fired (until a Ping and PingFailsafeReset).
  bool failsafe_triggered() const { return device_.failsafe_triggered(); }

 private:
  // Any other Stream (or a core without the rings): out of line, its buffer off poll()'s frame.
  __attribute__((noinline)) void drain_stream(tether::Millis now) {
    tether::arduino::drain_copy(hardware_, stream_, [this, now](tether::ByteView run) { return device_.handle_bytes(run, now); });
  }
  Stream& stream_;
  HardwareSerial* hardware_;  // stream_ when it is one of the core's HardwareSerial ports, else null
  tether::proxy::device::OutputTable outputs_;
  tether::proxy::device::ProxyDevice device_;
};

/// The deployed uORocketry variant on a `Stream` (its hosts expect 57600 8N1).
class TetherProxyCompat {
 public:
  /// Device talking through `stream`; `begin()` it after `stream.begin(...)`. One of the core's hardware
  /// ports is read in place (as `TetherProxy`'s).
  explicit TetherProxyCompat(Stream& stream)
      : stream_(stream),
        hardware_(tether::arduino::core_serial(&stream)),
        device_(tether::proxy::device::FrameSink{tether::arduino::write_frame, &stream}, tether::arduino::restart,
                &stream) {}
  /// Device talking through the core's hardware port `serial` (`Serial`): the fast path.
  explicit TetherProxyCompat(HardwareSerial& serial)
      : stream_(serial),
        hardware_(&serial),
        device_(tether::proxy::device::FrameSink{tether::arduino::write_frame_hardware, &serial},
                tether::arduino::restart, static_cast<Stream*>(&serial)) {}
  TetherProxyCompat(const TetherProxyCompat&) = delete;
  TetherProxyCompat& operator=(const TetherProxyCompat&) = delete;

  /// End of setup: takes Timer1, sends EventMessage{RESET}.
  void begin() {
    tether::arduino::release_timer1();
    device_.begin(millis());
  }
  /// Call from loop(): handles received bytes and the 50 ms state stream.
  void poll() {
    if (!tether::arduino::drain_ring(hardware_, [this](tether::ByteView run) { return device_.handle_bytes(run); })) {
      drain_stream();
    }
    device_.poll(millis());
  }

 private:
  // As TetherProxy's.
  __attribute__((noinline)) void drain_stream() {
    tether::arduino::drain_copy(hardware_, stream_, [this](tether::ByteView run) { return device_.handle_bytes(run); });
  }
  Stream& stream_;
  HardwareSerial* hardware_;  // stream_ when it is one of the core's HardwareSerial ports, else null
  tether::proxy::device::CompatDevice device_;
};
