// TetherProxy's ProxyCompat example (the deployed variant: COBS without CRC, 57600), measured as ProxyBench
// (bench/README.md): the host puts a whole frame into Serial's receive ring, then writes a row id to GPIOR1;
// the next loop pass runs one poll() between two GPIOR0 writes with interrupts held.
#include <TetherProxy.h>

TetherProxyCompat proxy(Serial);

void setup() {
  Serial.begin(57600);
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
