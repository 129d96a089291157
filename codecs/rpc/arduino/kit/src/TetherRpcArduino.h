/// @file TetherRpcArduino.h
/// The Arduino glue of a library `tether generate` writes: a schema's service (`<Name>_service.h`) served
/// by the rpc device runtime (tether/rpc/device/rpc_device.hpp) over a `Stream`, with the Arduino core's
/// `millis()` as its clock. The generated `<Name>.h` names it (`class ArmRpc : public RpcDevice<...>`):
///
///     #include <ArmRpc.h>
///     tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) { ... }
///     ArmRpc device(Serial);
///     void setup() { Serial.begin(115200); device.begin(); }
///     void loop() { device.poll(); }
///
/// Bytes move in runs (TetherArduinoStream.h): on the core's `HardwareSerial` the receive ring is handed to
/// the decoder in place and frames are copied into the transmit ring in one pass; any other `Stream` gets
/// one available() per run of up to 64 bytes and Print's write(buffer, size) per frame. The boot's session
/// id is the proxy's (the last 8 bytes of EEPROM); Reset restarts through the watchdog.
#pragma once

#include <Arduino.h>
#include <TetherCore.h>  // first: the Arduino builder finds the TetherCore library by this name

// TetherProxy and this library each carry the proxy's framing and the nanopb runtime (each configured its
// own way: 64-bit fields on here): one sketch cannot have both.
#ifdef TETHER_ARDUINO_PROXY_LIBRARY
#error "TetherProxy and a library written by tether generate cannot share a sketch: both carry the proxy framing and the nanopb runtime (docs/arduino.md)"
#endif
/// Defined by TetherRpcArduino.h: TetherProxy.h refuses to join it (see above).
#define TETHER_ARDUINO_RPC_LIBRARY 1

#include "TetherArduinoStream.h"
#include "TetherSetArduinoMacrosAside.h"  // Arduino.h's bit, min, max, ... would rewrite Tether's names
#include "tether/proxy/device/session_id.hpp"
#include "tether/rpc/device/rpc_device.hpp"
#include "TetherRestoreArduinoMacros.h"

namespace tether {
namespace arduino {

/// Frame sink writing to the `Stream` passed as context (blocks while its buffer is full).
void rpc_write_frame(void* stream, ByteView frame);
/// Frame sink writing to the `HardwareSerial` passed as context, into its transmit ring in one pass.
void rpc_write_frame_hardware(void* serial, ByteView frame);
/// Restart hook: flushes the `Stream` passed as context (the Reset's ack must leave), resets through the
/// watchdog.
void rpc_restart(void* stream);

/// The shortest stream period at `baud`: one frame of `max_payload` bytes (10 bits a byte), rounded up, so
/// that a stream never sends faster than the line carries it.
inline uint16_t rpc_min_period_ms(size_t max_payload, uint32_t baud) {
  const uint32_t bits = static_cast<uint32_t>(proxy::max_frame_size(max_payload)) * 10u * 1000u;
  return static_cast<uint16_t>((bits + baud - 1u) / baud);
}

/// A schema's service on a `Stream`; `ServiceCode` is the generated `<Name>Service`. Not copyable; use it
/// from loop() only (never from an interrupt).
template <class ServiceCode>
class RpcDevice {
 public:
  /// Device talking through `stream` (SoftwareSerial, a USB port, ...); `begin()` it after `stream.begin`.
  /// Both constructors are constant: a global device needs no start-up code (zeros in .bss).
  constexpr explicit RpcDevice(Stream& stream)
      : stream_(stream),
        hardware_(nullptr),
        device_(ServiceCode::service(), rpc::device::FrameSink{rpc_write_frame, &stream}, rpc_restart, &stream) {}
  /// Device talking through the core's hardware port `serial` (`Serial`): the fast path.
  constexpr explicit RpcDevice(HardwareSerial& serial)
      : stream_(serial),
        hardware_(&serial),
        device_(ServiceCode::service(), rpc::device::FrameSink{rpc_write_frame_hardware, &serial}, rpc_restart,
                static_cast<Stream*>(&serial)) {}
  RpcDevice(const RpcDevice&) = delete;
  RpcDevice& operator=(const RpcDevice&) = delete;

  /// End of setup: derives this boot's session id, sets the shortest stream period for `baud` (the one
  /// given to `Serial.begin`), sends ResetEvent.
  __attribute__((noinline)) void begin(uint32_t baud = 115200) {
    const uint32_t session_id = proxy::device::boot_session_id();
    device_.set_min_period_ms(rpc_min_period_ms(ServiceCode::Limits::kMaxOutPayload, baud == 0 ? 115200 : baud));
    device_.begin(session_id, millis());
  }
  /// Call from loop(): runs the calls whose bytes arrived, then what is due (stream messages, hellos, the
  /// ping failsafe). The answer buffers are static (counted in the sketch's RAM figure).
  void poll() {
    // One clock read per call, none per byte: the bytes waiting arrived before it.
    const Millis now = millis();
#if TETHER_ARDUINO_SERIAL_RINGS
    if (hardware_ != nullptr) {
      if (rx_waiting(*hardware_)) drain_ring(now);
    } else {
      drain_stream(now);
    }
#else
    drain_stream(now);
#endif
    run_timers(now);
  }
  /// The runtime's counters (frames, calls, stream messages, handler errors, refusals).
  const rpc::device::DeviceCounters& counters() const { return device_.counters(); }
  /// Streams the host keeps open now.
  uint8_t open_streams() const { return device_.open_streams(); }

 private:
#if TETHER_ARDUINO_SERIAL_RINGS
  // The receive ring in place, in runs (at most 64 bytes a call: a sender faster than the loop cannot keep
  // it from the timers); the decoder stops at each completed frame and is handed the rest.
  __attribute__((noinline)) void drain_ring(Millis now) {
    for (uint8_t taken = 0; taken < 64;) {
      const uint8_t* data;
      const uint8_t run = rx_run(*hardware_, data);
      if (run == 0) return;
      const uint8_t used = static_cast<uint8_t>(device_.handle_bytes(ByteView(data, run), now));
      rx_consume(*hardware_, used);
      taken = static_cast<uint8_t>(taken + used);
    }
  }
#endif
  // Up to 64 bytes copied out with one available(), handed over in runs.
  __attribute__((noinline)) void drain_stream(Millis now) {
    uint8_t run[64];
    const uint8_t count = read_run(hardware_, stream_, run, sizeof run);
    for (uint8_t used = 0; used != count;) {
      used = static_cast<uint8_t>(used + device_.handle_bytes(ByteView(run + used, static_cast<size_t>(count - used)), now));
    }
  }
  __attribute__((noinline)) void run_timers(Millis now) { device_.poll(now); }

  // The schema's sizes, with the answer buffers in static RAM: the build's RAM figure counts them, so a
  // schema too large for the board fails the build ("not enough memory") instead of overflowing the stack
  // at its first large answer.
  struct Limits : ServiceCode::Limits {
    static constexpr bool kStaticBuffers = true;
  };

  Stream& stream_;
  HardwareSerial* hardware_;  // stream_ when it is the core's HardwareSerial, else null
  rpc::device::Device<Limits> device_;

#if defined(RAMEND) && defined(RAMSTART)
  // The device's tables and answer buffers alone over the board's RAM: said here, before the linker's
  // "section .bss is not within region data".
  static constexpr size_t kDeviceRam = sizeof(rpc::device::Device<Limits>) + Limits::kMaxOutPayload +
                                       proxy::max_frame_size(Limits::kMaxOutPayload) + Limits::kRequestStructBytes +
                                       Limits::kReplyStructBytes;
  static_assert(kDeviceRam <= static_cast<size_t>(RAMEND - RAMSTART + 1),
                "this schema's rpc device needs more RAM than the board has: lower the .options bounds "
                "(max_size, max_count) of its largest messages");
#endif
};

}  // namespace arduino
}  // namespace tether
