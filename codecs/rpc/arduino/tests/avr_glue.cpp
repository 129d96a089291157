// Instantiates the generated ArmRpc library's glue for the AVR warning gate (check-avr-glue.cmake): both
// constructors' paths (the core's Serial, any Stream) and every entry point.
#include <ArmRpc.h>

ArmRpc on_serial(Serial);
ArmRpc on_stream(static_cast<Stream&>(Serial));

void use() {
  on_serial.begin();
  on_serial.poll();
  on_stream.begin(9600);
  on_stream.poll();
  (void)on_serial.counters();
  (void)on_stream.open_streams();
}
