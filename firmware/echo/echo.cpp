// Echo image: prints the banner "tether echo\r\n", then sends every received byte back unchanged, forever.
// The host transport tests use it as the far end of a serial link (simulated or real).
//
// Buffer sizes: at 115200 8N1 bytes arrive and leave at the same line rate, and the loop copies in
// chunks far faster than that, so the rings only absorb the banner and rate mismatch: the Uno sends at
// 117647 bit/s (UBRR0=16, +2.1%), faster than a host at 115200, but a host clock running fast by up
// to ~2.5% would gain ~2.5 bytes per 100. 128 bytes each way covers a 5 kB burst at that worst-case skew
// and keeps the RX ring ahead of the loop while it waits for TX room. 256 of the 2048 bytes of RAM.
#include "tether/core/bytes.hpp"
#include "tether/firmware/runtime.hpp"

namespace {

using Serial = tether::firmware::Uart0<128, 128>;
constexpr uint32_t kBaud = 115200;

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(kBaud);
  Serial::write(tether::ByteView::from_literal("tether echo\r\n"));
  uint8_t chunk[32];
  for (;;) {
    const size_t count = Serial::read(tether::MutableByteView(chunk));
    if (count == 0) {
      tether::firmware::idle<Serial>();
      continue;
    }
    Serial::write(tether::ByteView(chunk, count));  // waits (asleep) while the TX ring is full
  }
}
