/// @file ArduinoSerial.h
/// RomiSerial compatibility header: `romiserial::ArduinoSerial`, a byte stream over an Arduino `Stream`
/// such as `Serial` (tether/romi/device/arduino_serial.hpp). Arduino builds only: without `ARDUINO`
/// defined it declares nothing.
#pragma once

#include "IInputStream.h"
#include "IOutputStream.h"
#include "tether/romi/device/arduino_serial.hpp"

#ifdef ARDUINO
namespace romiserial {
/// See tether::romi::device::ArduinoSerial.
using tether::romi::device::ArduinoSerial;
}  // namespace romiserial
#endif
