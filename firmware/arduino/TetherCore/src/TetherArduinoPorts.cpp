// Which of the Arduino core's hardware ports a `Stream` is (TetherArduinoStream.h, `core_serial`): TetherCore's,
// so once in a sketch whatever the Tether libraries it uses.
//
// The ports are referenced weakly, and only here: a weak reference does not pull a port's object file
// (HardwareSerial0.cpp: the object, its 157 bytes of RAM and its interrupts) out of the core's archive, so a
// sketch that never uses `Serial` does not link it, and its address is then 0. Not in a header: a weak
// declaration in the sketch's own file would make the sketch's own uses weak too, and `Serial` would then
// not be linked at all.
#include "TetherArduinoStream.h"

#if defined(HAVE_HWSERIAL0)
extern HardwareSerial Serial __attribute__((weak));
#endif
#if defined(HAVE_HWSERIAL1)
extern HardwareSerial Serial1 __attribute__((weak));
#endif
#if defined(HAVE_HWSERIAL2)
extern HardwareSerial Serial2 __attribute__((weak));
#endif
#if defined(HAVE_HWSERIAL3)
extern HardwareSerial Serial3 __attribute__((weak));
#endif

namespace tether {
namespace arduino {

HardwareSerial* core_serial(Stream* stream) {
  if (stream == nullptr) return nullptr;
  // Compared as addresses: a port that is not linked has address 0, which no stream has.
#if defined(HAVE_HWSERIAL0)
  if (stream == static_cast<Stream*>(&Serial)) return &Serial;
#endif
#if defined(HAVE_HWSERIAL1)
  if (stream == static_cast<Stream*>(&Serial1)) return &Serial1;
#endif
#if defined(HAVE_HWSERIAL2)
  if (stream == static_cast<Stream*>(&Serial2)) return &Serial2;
#endif
#if defined(HAVE_HWSERIAL3)
  if (stream == static_cast<Stream*>(&Serial3)) return &Serial3;
#endif
  return nullptr;
}

}  // namespace arduino
}  // namespace tether
