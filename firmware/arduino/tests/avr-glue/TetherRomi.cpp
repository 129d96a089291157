// Instantiates TetherRomi's glue for the AVR warning gate (check-avr-glue.cmake): both ArduinoSerial paths.
#include <ArduinoSerial.h>
#include <RomiSerial.h>

romiserial::ArduinoSerial hardware(Serial);
romiserial::ArduinoSerial stream(static_cast<Stream&>(Serial));

void use() {
  uint8_t bytes[4];
  hardware.write_all(bytes, hardware.read_some(bytes, sizeof bytes));
  hardware.write('#');
  stream.write_all(bytes, stream.read_some(bytes, sizeof bytes));
  stream.write('#');
}
