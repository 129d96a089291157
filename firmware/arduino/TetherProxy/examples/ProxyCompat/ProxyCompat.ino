// The `proxy-compat` image as a sketch: what uORocketry's deployed firmware speaks (COBS + RocketryProto,
// no CRC, 57600 8N1), so existing rocketry hosts drive it unchanged: servos on any pin, digital outputs,
// DC motors, the HX711 load cell on D12 (DOUT) / D13 (PD_SCK), a state stream every 50 ms.
#include <TetherProxy.h>

TetherProxyCompat proxy(Serial);

void setup() {
  Serial.begin(57600);
  proxy.begin();  // sends EventMessage{RESET}
}

void loop() {
  proxy.poll();
}
