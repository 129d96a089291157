// Instantiates TetherElcano's glue for the AVR warning gate (check-avr-glue.cmake): both input paths.
#include <ElcanoSerial.h>

elcano::ParseState ps;

void use() {
  ps.input = &Serial;
  ps.update();
  ps.input = static_cast<Stream*>(&Serial);
  ps.update();
  ps.input = nullptr;
}
