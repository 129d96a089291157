/// @file IOutputStream.h
/// RomiSerial compatibility (`romiserial::IOutputStream`): the byte sink a `RomiSerialClient` writes.
#pragma once

namespace romiserial {

/// Byte-at-a-time output, as RomiSerial's host classes use it.
class IOutputStream {
 public:
  virtual ~IOutputStream() = default;
  /// Writes one byte; false when the stream failed.
  virtual bool write(char c) = 0;
};

}  // namespace romiserial
