// default_clock() for Arduino builds: the Arduino core's millis() (Timer0). Compiled to nothing elsewhere.
#ifdef ARDUINO

#include <Arduino.h>

#include "tether/romi/device/romi_serial.hpp"

uint32_t tether::romi::device::default_clock() { return millis(); }

#endif  // ARDUINO
