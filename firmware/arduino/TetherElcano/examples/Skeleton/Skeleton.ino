// The ElcanoSerial README's usage skeleton on an Uno: its one UART (Serial) is both the input (from the
// previous board) and the output (to the next). This node captures drive messages and forwards the rest.
#include <ElcanoSerial.h>

elcano::ParseState ps;
elcano::SerialData dt;

void setup() {
  Serial.begin(elcano::baudrate);

  ps.dt     = &dt;
  ps.input  = &Serial;
  ps.output = &Serial;
  ps.capture = elcano::MsgType::drive;
  dt.clear();

  // Any other initialization code goes here
}

void loop1() {
  // Update code here that depends on having recieved a data set
}

void loop2() {
  // Update code here that does not depend on having received a data set
}

void loop() {
  elcano::ParseStateError r = ps.update();
  if (r == elcano::ParseStateError::success) {
    loop1();
  }

  loop2();
}
