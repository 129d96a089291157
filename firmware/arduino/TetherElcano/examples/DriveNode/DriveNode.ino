// A ring node that captures drive messages (ElcanoSerial API): each drive lights the LED while the speed
// is not 0 and is answered with a sensor report of the same speed and angle, sent on round the ring.
// Everything else is forwarded. The Uno's one UART is the ring: RX from the previous board, TX to the next.
#include <ElcanoSerial.h>

elcano::ParseState ps;
elcano::SerialData dt;

void setup() {
  Serial.begin(elcano::baudrate);
  ps.dt = &dt;
  ps.input = &Serial;
  ps.output = &Serial;
  ps.capture = elcano::MsgType::drive;
  dt.clear();
  pinMode(LED_BUILTIN, OUTPUT);
}

void report(const elcano::SerialData& drive) {
  elcano::SerialData sensor;
  sensor.kind = elcano::MsgType::sensor;
  sensor.speed_cmPs = drive.speed_cmPs;
  sensor.angle_deg = drive.angle_deg;
  sensor.bearing_deg = 0;
  sensor.posE_cm = 0;
  sensor.posN_cm = 0;
  ps.write(sensor);  // through the node: paced, and dropped here if nobody captures it
}

void loop() {
  if (ps.update() == elcano::ParseStateError::success) {
    digitalWrite(LED_BUILTIN, dt.speed_cmPs != 0 ? HIGH : LOW);
    report(dt);
  }
}
