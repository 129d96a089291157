// TetherProxy's Proxy example over a plain Stream: Serial passed as a `Stream&`, so the library takes the
// path every non-HardwareSerial port gets (SoftwareSerial, a USB port, a sketch's own Stream): one virtual
// available() per run, the stream's read() per byte (its target looked up once per run), frames through
// Print::write. Measured as ProxyBench (bench/README.md): the host puts a whole frame into Serial's receive
// ring, then writes a row id to GPIOR1; the next loop pass runs one poll() between two GPIOR0 writes with
// interrupts held.
#include <TetherProxy.h>

TetherProxy proxy(static_cast<Stream&>(Serial));

void setup() {
  Serial.begin(115200);
  proxy.begin();
}

void loop() {
  const uint8_t row = GPIOR1;
  if (row == 0) return;
  GPIOR1 = 0;
  cli();
  GPIOR0 = row;
  proxy.poll();
  GPIOR0 = 0;
  sei();
}
