// default_clock() on Tether's bare-metal runtime: tether::firmware::millis() (Timer2, firmware/runtime).
// Only the CMake AVR build compiles this file; the Arduino library uses clock_arduino.cpp instead.
#ifndef ARDUINO

#include "tether/firmware/clock.hpp"
#include "tether/romi/device/romi_serial.hpp"

uint32_t tether::romi::device::default_clock() { return tether::firmware::millis(); }

#endif  // !ARDUINO
