/// @file IRomiSerialClient.h
/// RomiSerial compatibility (`romiserial::IRomiSerialClient`): the interface programs hold clients by.
#pragma once

#include <nlohmann/json.hpp>

namespace romiserial {

/// A Romi request/response client (see `RomiSerialClient`).
class IRomiSerialClient {
 public:
  virtual ~IRomiSerialClient() = default;
  /// Sends `command` (`"L[1]"`) and puts the answer array, code first, into `response`.
  virtual void send(const char* command, nlohmann::json& response) = 0;
  /// Logs every request and answer through the client's `ILog::debug` when on.
  virtual void set_debug(bool value) = 0;
};

}  // namespace romiserial
