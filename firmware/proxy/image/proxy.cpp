// The `proxy` image: an Arduino Uno as the host's I/O proxy, primary mode of the proxy protocol.
// UART0 at 115200 8N1; frames COBS(crc16 ‖ protobuf) ‖ 00; servos on D9/D10 (Timer1 PWM), digital outputs
// on 2..19; acks, exactly-once per messageId, 10 s ping failsafe, ArduinoInfo every 5 s, Reset through the
// watchdog. The wire behaviour is documented in tether/proxy/device/proxy_device.hpp, the sessionId in
// tether/proxy/device/session_id.hpp (it uses the last 8 bytes of EEPROM).
//
// Buffers: RX ring 128 bytes: the host keeps at most a few messages (<= 25 bytes of payload each) in flight,
// and the loop reads faster than the line delivers except while it waits for TX room; TX ring 64 bytes:
// `write` sleeps while the ring is full, so a burst (a failsafe sends an Error and up to 18 PinStates of
// ~13 bytes) only holds the loop for its line time (~25 ms at worst), while the RX ring keeps receiving.
#include "tether/core/bytes.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/proxy/device.hpp"

namespace {

using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;

// Byte by byte: the single-byte write path instead of the bulk copy's (-66 B of flash); a byte's extra
// cycles are small next to its line time at 115200 baud (1389 cycles of the 16 MHz clock).
void write_frame(void*, tether::ByteView frame) {
  for (const uint8_t byte : frame) Serial::write(byte);
}

void restart(void*) {
  Serial::flush();  // the Reset's ack must leave the UART first
  tether::firmware::system_reset();
}

tether::proxy::device::OutputTable outputs;
tether::proxy::device::ProxyDevice device(outputs, tether::proxy::device::FrameSink{write_frame, nullptr}, restart);

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  // First, before interrupts and before the stack grows: it reads the untouched SRAM (session_id.hpp).
  const uint32_t session_id = tether::proxy::device::boot_session_id();
  tether::firmware::runtime_init<Serial>(kBaud);
  device.begin(session_id, tether::firmware::millis());  // end of setup: ResetEvent
  for (;;) {
    // What the RX ring holds, read in place: a run of data bytes goes through the decoder's tight loop.
    const tether::ByteView received = Serial::peek();
    if (!received.empty()) {
      Serial::consume(static_cast<uint8_t>(device.handle_bytes(received, tether::firmware::millis())));
    }
    device.poll(tether::firmware::millis());
    if (received.empty()) tether::firmware::idle<Serial>();
  }
}
