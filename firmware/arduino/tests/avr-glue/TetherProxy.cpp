// Instantiates TetherProxy's glue for the AVR warning gate (check-avr-glue.cmake): every constructor's path.
#include <TetherProxy.h>

TetherProxy primary(Serial);
TetherProxy primary_stream(static_cast<Stream&>(Serial));
TetherProxyCompat compat(Serial);
TetherProxyCompat compat_stream(static_cast<Stream&>(Serial));

void use() {
  primary.poll();
  primary_stream.poll();
  compat.poll();
  compat_stream.poll();
}
