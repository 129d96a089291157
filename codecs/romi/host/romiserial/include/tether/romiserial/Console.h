/// @file Console.h
/// RomiSerial compatibility (`romiserial::Console`): an `ILog` that prints to the terminal.
#pragma once

#include <cstdarg>

#include "ILog.h"

namespace romiserial {

/// Prints each message as one line `<level>: <text>` on stderr (stdout stays the program's own output).
class Console : public ILog {
 public:
  Console() = default;
  ~Console() override = default;
  /// `error: <text>`.
  void error(const char* format, ...) override __attribute__((format(printf, 2, 3)));
  /// `warning: <text>`.
  void warn(const char* format, ...) override __attribute__((format(printf, 2, 3)));
  /// `debug: <text>`.
  void debug(const char* format, ...) override __attribute__((format(printf, 2, 3)));

 protected:
  /// Writes one line, whole (one write, so lines of several threads do not interleave).
  void print(const char* level, const char* format, va_list arguments) __attribute__((format(printf, 3, 0)));
};

}  // namespace romiserial
