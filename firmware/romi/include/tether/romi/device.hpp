/// @file device.hpp
/// Tether's Romi device library in one include (firmware side of the Romi text protocol).
///
/// - device/romi_serial.hpp: `RomiSerial`, the device (wire behaviour, memory, counters): start here;
/// - device/handler.hpp: `MessageHandler` table rows and `IRomiSerial`, the handler contract;
/// - device/streams.hpp: `IInputStream` / `IOutputStream`, the byte streams it talks through;
/// - device/uart_stream.hpp: `UartStream<Uart>` over Tether's runtime UART;
/// - device/arduino_serial.hpp: `ArduinoSerial` over an Arduino `Stream` (Arduino builds only);
/// - device/array_text.hpp: `ArrayText`, reply text such as "[0,512]" without printf.
/// Sketches written for the reference RomiSerial include `RomiSerial.h` / `ArduinoSerial.h` instead,
/// which bring the same classes into namespace `romiserial`.
#pragma once

#include "tether/romi/device/arduino_serial.hpp"
#include "tether/romi/device/array_text.hpp"
#include "tether/romi/device/handler.hpp"
#include "tether/romi/device/romi_serial.hpp"
#include "tether/romi/device/streams.hpp"
#include "tether/romi/device/uart_stream.hpp"
