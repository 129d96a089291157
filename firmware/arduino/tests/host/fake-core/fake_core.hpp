// The fake core's test hooks (see Arduino.h here).
#pragma once

#include <Arduino.h>

#include <vector>

namespace fake_core {
/// Every byte written to a fake UART's data register, in order.
extern std::vector<uint8_t> wire;
/// The UART of `Serial`.
extern FakeUart serial_uart;
/// Sends what `serial` wrote: the byte in its data register, then its transmit interrupt until its ring is
/// empty (the interrupt disables itself).
void transmit(HardwareSerial& serial, FakeUart& uart);
}  // namespace fake_core
