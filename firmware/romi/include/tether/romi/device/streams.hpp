/// @file streams.hpp
/// The two byte streams a `RomiSerial` device talks through, shaped like the reference RomiSerial's
/// `IInputStream` / `IOutputStream` so stream classes written for it keep working.
///
/// Implementations shipped with Tether:
///   - `UartStream<Uart>` (uart_stream.hpp): Tether's bare-metal runtime, `tether::firmware::Uart0<...>`;
///   - `ArduinoSerial` (ArduinoSerial.h, Arduino builds only): any Arduino `Stream`, e.g. `Serial`.
///
/// Both interfaces have a protected, non-virtual destructor: objects are never deleted through them
/// (a virtual destructor would need `operator delete`, which bare-metal AVR images do not have).
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {
namespace romi {
namespace device {

/// Where a device reads request bytes from.
class IInputStream {
 public:
  /// True when `read()` would deliver a byte now. Must not block.
  virtual bool available() = 0;
  /// Stores the next byte in `c` and returns true, or returns false when none is waiting. Must not block.
  virtual bool read(char& c) = 0;

 protected:
  ~IInputStream() = default;
};

/// Where a device writes response and log frames to.
class IOutputStream {
 public:
  /// Queues one byte for sending; may block while the transmitter is busy (it must not drop the byte
  /// silently). Returns false if the byte could not be sent at all (the device ignores the value: a
  /// lost reply byte is repaired by the host's retry and the device's reply cache).
  virtual bool write(char c) = 0;

 protected:
  ~IOutputStream() = default;
};

}  // namespace device
}  // namespace romi
}  // namespace tether
