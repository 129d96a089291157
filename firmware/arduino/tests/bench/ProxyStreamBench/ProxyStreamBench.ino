// TetherProxy's Proxy example with Serial passed as a plain `Stream&` (`TetherProxy proxy(port)` where a
// sketch holds its port as a `Stream&`): the library recognises the core's port behind the reference and
// reads its receive ring in place, as with `TetherProxy proxy(Serial)` (frames still go out through the
// Stream). Measured as ProxyBench (bench/README.md): the host puts a whole frame into Serial's receive ring,
// then writes a row id to GPIOR1; the next loop pass runs one poll() between two GPIOR0 writes with
// interrupts held. ProxyOwnStreamBench measures the path of every other Stream.
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
