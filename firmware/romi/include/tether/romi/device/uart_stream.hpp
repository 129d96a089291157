/// @file uart_stream.hpp
/// Adapter from Tether's bare-metal UART (`tether::firmware::Uart0<Rx, Tx>`, firmware/runtime) to the
/// device's byte streams, so a `RomiSerial` runs on the Tether runtime without the Arduino core:
///
///     using Serial = tether::firmware::Uart0<128, 128>;
///     TETHER_UART0_ISRS(Serial);
///     tether::romi::device::UartStream<Serial> serial;
///     tether::romi::device::RomiSerial romi(serial, serial, handlers, count);
///
/// Header-only and stateless (the UART's rings are static); works with any `Uart` type providing
/// static `available()`, `read()` (-1 when empty), `read(MutableByteView)`, `write_now(uint8_t)` and
/// `write(ByteView)`.
#pragma once

#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/romi/device/streams.hpp"

namespace tether {
namespace romi {
namespace device {

/// Input and output stream over the static UART `Uart`.
template <typename Uart>
class UartStream final : public IInputStream, public IOutputStream {
 public:
  /// True when the RX ring holds a byte.
  bool available() override { return Uart::available() != 0; }
  /// Takes the next byte from the RX ring.
  bool read(char& c) override {
    const int16_t byte = Uart::read();
    if (byte < 0) return false;
    c = static_cast<char>(byte);
    return true;
  }
  /// Takes up to `capacity` bytes from the RX ring in one pass.
  uint8_t read_some(uint8_t* bytes, uint8_t capacity) override {
    return static_cast<uint8_t>(Uart::read(MutableByteView(bytes, capacity)));
  }
  /// Queues `c` on the TX ring, or puts it straight into the idle transmitter (`Uart::write_now`: a
  /// reply's first byte, the device's turnaround); sleeps (IDLE) while the ring is full. Always true.
  bool write(char c) override {
    Uart::write_now(static_cast<uint8_t>(c));
    return true;
  }
  /// Queues `bytes` on the TX ring, sleeping while it is full.
  void write_all(const uint8_t* bytes, uint8_t size) override { Uart::write(ByteView(bytes, size)); }
};

}  // namespace device
}  // namespace romi
}  // namespace tether
