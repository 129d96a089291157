/// @file IOutputStream.h
/// RomiSerial compatibility header: `romiserial::IOutputStream`, implemented by Tether
/// (tether/romi/device/streams.hpp).
#pragma once

#ifdef ARDUINO
// First, so that the Arduino builder finds the TetherCore library (tether/core/) by this name.
#include <TetherCore.h>
#endif

#include "tether/romi/device/streams.hpp"

namespace romiserial {
/// See tether::romi::device::IOutputStream.
using tether::romi::device::IOutputStream;
}  // namespace romiserial
