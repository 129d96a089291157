// TetherElcano's DriveNode example (a ring node on Serial capturing drives, and here segments), for tether_avr_cycle_report:
// the host puts a whole message into Serial's receive ring, then writes a row id to GPIOR1; the next loop
// pass runs one ps.update() between two GPIOR0 writes (the row id, then 0) with interrupts held, and
// writes its outcome + 1 to GPIOR2 (bench/README.md).
#include <ElcanoSerial.h>

elcano::ParseState ps;
elcano::SerialData dt;

void setup() {
  Serial.begin(elcano::baudrate);
  ps.dt = &dt;
  ps.input = &Serial;
  ps.output = &Serial;
  ps.capture = elcano::MsgType::drive | elcano::MsgType::seg;  // DriveNode captures drives; segments too here
  dt.clear();
  pinMode(LED_BUILTIN, OUTPUT);
}

void loop() {
  const uint8_t row = GPIOR1;
  if (row == 0) return;
  GPIOR1 = 0;
  cli();
  GPIOR0 = row;
  const elcano::ParseStateError outcome = ps.update();
  GPIOR0 = 0;
  sei();
  GPIOR2 = static_cast<uint8_t>(static_cast<uint8_t>(outcome) + 1);
  if (outcome == elcano::ParseStateError::success) digitalWrite(LED_BUILTIN, dt.speed_cmPs != 0 ? HIGH : LOW);
}
