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
  /// Stores up to `capacity` waiting bytes in `bytes`; returns how many (0: none waiting). Must not
  /// block. Fewer than `capacity` tells the device that the stream is drained: it reads again at its
  /// next `handle_input()`, not at once. The default asks `available()` once per call (the device's
  /// polls mostly find nothing: then that is all they cost), then calls `read` per byte until it finds
  /// none or `capacity` is reached; a stream over a buffer overrides it to copy them in one call (the
  /// device's byte loop then makes one virtual call per batch, not per byte).
  virtual uint8_t read_some(uint8_t* bytes, uint8_t capacity) {
    if (!available()) return 0;
    uint8_t count = 0;
    char c;
    while (count < capacity && read(c)) bytes[count++] = static_cast<uint8_t>(c);
    return count;
  }

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
  /// Queues `size` bytes, as `write` does each. The default calls `write` per byte; a stream over a
  /// buffer overrides it to copy them in one call.
  virtual void write_all(const uint8_t* bytes, uint8_t size) {
    for (uint8_t i = 0; i < size; ++i) write(static_cast<char>(bytes[i]));
  }

 protected:
  ~IOutputStream() = default;
};

}  // namespace device
}  // namespace romi
}  // namespace tether
