// The `proxy` image as a sketch: the host's I/O proxy in primary mode (COBS + CRC-16 + tether.proxy
// messages at 115200 8N1). The host initialises servos on D9/D10 and digital outputs on 2..19, commands
// them, pings every second; 10 s without a ping drives every initialised pin to its safe value.
#include <TetherProxy.h>

TetherProxy proxy(Serial);

void setup() {
  Serial.begin(115200);
  proxy.begin();  // sends ResetEvent with this boot's sessionId
}

void loop() {
  proxy.poll();
  // Other work goes here; keep each pass short (the proxy answers from poll()).
}
