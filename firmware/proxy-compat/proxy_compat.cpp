// The `proxy-compat` image: an Arduino Uno speaking the DEPLOYED variant of the proxy protocol, so existing
// rocketry hosts can drive it. UART0 at 57600 8N1; host to device `00 ‖ COBS(RocketryProto.ArduinoIn) ‖ 00`,
// device to host `COBS(RocketryProto.ArduinoOut) ‖ 00`; no CRC, ids, acks or ping. Servos on any pin with
// Arduino Servo timing (Timer1 interrupt), digital outputs, two DC motors (PWM on D5/D6), the HX711 load
// cell on D12 (DOUT) / D13 (PD_SCK), a state stream every 50 ms, Reset through the watchdog. Behaviour:
// tether/proxy/device/compat_device.hpp.
//
// Buffers: the state stream sends up to ~9 bytes per initialised pin every 50 ms (18 pins, 2 motors and the
// load cell: ~220 bytes, ~40 ms of the line at 57600), and `write` sleeps while the 128-byte TX ring is full; the 128-byte RX
// ring holds ~25 ms of host input at line rate meanwhile, far more than the deployed host sends.
#include "tether/core/bytes.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/proxy/device.hpp"

namespace {

using Serial = tether::firmware::Uart0<128, 128>;
constexpr uint32_t kBaud = 57600;

void write_frame(void*, tether::ByteView frame) { Serial::write(frame); }

void restart(void*) {
  Serial::flush();
  tether::firmware::system_reset();
}

tether::proxy::device::CompatDevice device(tether::proxy::device::FrameSink{write_frame, nullptr}, restart);

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(kBaud);
  device.begin(tether::firmware::millis());  // end of setup: EventMessage{RESET}
  uint8_t chunk[16];
  for (;;) {
    const size_t count = Serial::read(tether::MutableByteView(chunk));
    for (size_t i = 0; i < count; ++i) device.handle_byte(chunk[i]);
    device.poll(tether::firmware::millis());
    if (count == 0) tether::firmware::idle<Serial>();
  }
}
