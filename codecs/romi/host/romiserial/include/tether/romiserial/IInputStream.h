/// @file IInputStream.h
/// RomiSerial compatibility (`romiserial::IInputStream`): the byte source a `RomiSerialClient` reads.
#pragma once

namespace romiserial {

/// Byte-at-a-time input with a timeout, as RomiSerial's host classes use it.
class IInputStream {
 public:
  virtual ~IInputStream() = default;
  /// How long `available()` waits for a byte.
  virtual void set_timeout(double seconds) = 0;
  /// True when a byte can be read (waits up to the timeout).
  virtual bool available() = 0;
  /// Reads one byte into `c`; false when none arrived within the timeout or the stream failed.
  virtual bool read(char& c) = 0;
};

}  // namespace romiserial
