/// @file IRomiSerial.h
/// RomiSerial compatibility header: `romiserial::IRomiSerial`, `MessageHandler`, `MessageCallback`,
/// implemented by Tether (tether/romi/device/handler.hpp, where the handler contract is written down).
#pragma once

#ifdef ARDUINO
// First, so that the Arduino builder finds the TetherCore library (tether/core/) by this name.
#include <TetherCore.h>
#endif

#include "tether/romi/device/handler.hpp"

namespace romiserial {
/// See tether::romi::device::IRomiSerial (the handler contract).
using tether::romi::device::IRomiSerial;
/// See tether::romi::device::MessageCallback.
using tether::romi::device::MessageCallback;
/// See tether::romi::device::MessageHandler.
using tether::romi::device::MessageHandler;
}  // namespace romiserial
