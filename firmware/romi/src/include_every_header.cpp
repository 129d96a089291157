// Compile-only gate of the AVR build: every public header of the device library, and one instantiation
// of each template, so a header that stops compiling with avr-gcc fails the build even if no image
// uses it yet. Never linked into an image.
#include "ArduinoSerial.h"
#include "IInputStream.h"
#include "IOutputStream.h"
#include "IRomiSerial.h"
#include "MessageHandler.h"
#include "RomiSerial.h"
#include "tether/firmware/uart0.hpp"
#include "tether/romi/device.hpp"

namespace tether {
namespace romi {
namespace device {

template class ArrayText<3>;
template class UartStream<tether::firmware::Uart0<2, 256>>;

}  // namespace device
}  // namespace romi
}  // namespace tether
