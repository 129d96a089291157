/// @file ILog.h
/// RomiSerial compatibility (`romiserial::ILog`): the log sink RomiSerial's host classes report to.
/// Same shape as RomiSerial's, so programs written for it build against Tether unchanged.
#pragma once

namespace romiserial {

/// Where `RSerial` and `RomiSerialClient` report: printf-style messages, one call per message.
class ILog {
 public:
  virtual ~ILog() = default;
  /// Something failed (a port that cannot be opened).
  virtual void error(const char* format, ...) __attribute__((format(printf, 2, 3))) = 0;
  /// Something unexpected that the client handled (a malformed error answer).
  virtual void warn(const char* format, ...) __attribute__((format(printf, 2, 3))) = 0;
  /// Details: the firmware's log lines, and requests/answers when the client's debug is on.
  virtual void debug(const char* format, ...) __attribute__((format(printf, 2, 3))) = 0;
};

}  // namespace romiserial
