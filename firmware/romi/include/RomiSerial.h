/// @file RomiSerial.h
/// RomiSerial compatibility header: a sketch written for the reference RomiSerial library builds against
/// Tether with this header (and ArduinoSerial.h) in place of the reference's:
///
///     #include <ArduinoSerial.h>
///     #include <RomiSerial.h>
///     using namespace romiserial;
///     void handle_led(IRomiSerial* romiSerial, int16_t* args, const char* string_arg);
///     const static MessageHandler handlers[] = {{'L', 1, false, handle_led}};
///     ArduinoSerial serial(Serial);
///     RomiSerial romiSerial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));
///
/// The implementation is Tether's (tether/romi/device/romi_serial.hpp, which documents the wire
/// behaviour and the differences from the reference). Tether additions reachable from here:
/// `counters()` (diagnostics), `ArrayText` (reply text without printf), `UartStream` (Tether runtime),
/// `BasicRomiSerial<PayloadCapacity, ReplyCapacity>` (a device whose buffers fit its handlers: less RAM).
#pragma once

#include "IInputStream.h"
#include "IOutputStream.h"
#include "IRomiSerial.h"
#include "tether/romi/device/array_text.hpp"
#include "tether/romi/device/romi_serial.hpp"

namespace romiserial {
/// See tether::romi::device::RomiSerial.
using tether::romi::device::RomiSerial;
/// See tether::romi::device::BasicRomiSerial (a device sized to its handlers).
using tether::romi::device::BasicRomiSerial;
/// See tether::romi::device::RomiSerialBase (a device of any size).
using tether::romi::device::RomiSerialBase;
/// See tether::romi::device::DeviceCounters.
using tether::romi::device::DeviceCounters;
/// See tether::romi::device::DeviceLinkCounters.
using tether::romi::device::DeviceLinkCounters;
/// See tether::romi::device::ClockFunction.
using tether::romi::device::ClockFunction;
/// See tether::romi::device::ArrayText.
using tether::romi::device::ArrayText;
}  // namespace romiserial
