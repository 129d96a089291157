// TetherProxy's Proxy example over a sketch's own Stream: a class that relays Serial (as a sketch wraps a
// port to log or filter its bytes), so the library takes the path of every port that is not one of the
// core's HardwareSerial objects (SoftwareSerial, a USB port, a sketch's own Stream): one virtual available()
// per run, the stream's read() per byte, frames through Print::write. Measured as ProxyBench
// (bench/README.md): the host puts a whole frame into Serial's receive ring, then writes a row id to GPIOR1;
// the next loop pass runs one poll() between two GPIOR0 writes with interrupts held.
#include <TetherProxy.h>

class Relay : public Stream {
 public:
  int available() override { return Serial.available(); }
  int read() override { return Serial.read(); }
  int peek() override { return Serial.peek(); }
  size_t write(uint8_t byte) override { return Serial.write(byte); }
  int availableForWrite() override { return Serial.availableForWrite(); }
  void flush() override { Serial.flush(); }
};

Relay relay;
TetherProxy proxy(relay);

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
