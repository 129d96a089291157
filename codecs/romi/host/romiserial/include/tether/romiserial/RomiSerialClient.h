/// @file RomiSerialClient.h
/// RomiSerial compatibility (`romiserial::RomiSerialClient`): RomiSerial's C++ host client, implemented on
/// Tether's `tether::romi::Client`, so programs written for RomiSerial build against Tether unchanged and
/// get its session engine: a 1 s attempt window within a 2 s call budget (RomiSerial could take ~6 s),
/// re-sends on damaged frames, stale answers never pinned on the wrong request, long log lines and answers
/// read (RomiSerial stops at 57 characters), and exactly-once with Tether firmware.
///
/// @code
///   auto log = std::make_shared<Console>();
///   auto serial = std::make_shared<RSerial>(device, 115200, true, log);
///   RomiSerialClient romiClient(serial, serial, log, 0, "blink");
///   nlohmann::json response;
///   romiClient.send("L[1]", response);   // response: [0]
///   romiClient.send("A", response);      // response: [0, 512]; response[1] is the value
///   romiClient.send("Z", response);      // response: [-16, "unknown opcode"]
/// @endcode
///
/// What `response` holds, as in RomiSerial: `response[kStatusCode]` is the code (0 success, > 0 the
/// application's, < 0 the protocol's, see `tether/romi/errors.hpp`); on success the device's values follow;
/// on an error `response` is exactly `[code, "message"]`: the device's message, else the code's text
/// (`get_error_message`). Nothing is thrown for a failed call: a timeout is `[-25, ...]`, a command rejected
/// before sending `[-24, ...]` (empty), `[-14, ...]` (opcode), `[-22, ...]` (too long), ..., a port that
/// failed `[-33, ...]`, an error answer that is not `[code]` or `[code, "text"]` `[-28, ...]`, an answer
/// that is not JSON `[-26, ...]` (RomiSerial threw, defect B5).
///
/// Like RomiSerial, ':' in a command is sent as '-'. Differences: the client runs on an `RSerial` only (in
/// and out the same object, which it takes over; anything else throws `std::invalid_argument`); the
/// firmware's log lines go to `log->debug` as they arrive, also between calls.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "IInputStream.h"
#include "ILog.h"
#include "IOutputStream.h"
#include "IRomiSerialClient.h"
#include "RSerial.h"

namespace romiserial {

/// Indexes into a response.
enum {
  kStatusCode = 0,    ///< The code: 0 success.
  kErrorMessage = 1,  ///< The message of an error response.
};

/// How long one call may take in all, in seconds (Tether's call budget; each attempt waits 1 s).
static const double kRomiSerialClientTimeout = 2.0;
/// The Romi protocol's baud rate.
static const uint32_t kDefaultBaudRate = 115200;

/// RomiSerial's host client on Tether (see the file overview). Calls from several threads are safe and
/// run one at a time, in order.
class RomiSerialClient : public IRomiSerialClient {
 public:
  /// A client for `device` at 115200 baud without reset on close, starting at a random id.
  static std::unique_ptr<IRomiSerialClient> create(const std::string& device, const std::string& client_name,
                                                    std::shared_ptr<ILog> log);
  /// A random start id, 0..254 (a new session never looks like the previous one's repeat).
  static uint8_t any_id();

  /// Client over `in`/`out`, which must be the same `RSerial`; the first request uses id `start_id + 1`
  /// (as in RomiSerial). `client_name` prefixes its log messages. Throws `std::invalid_argument` for
  /// streams that are not one `RSerial`, or an `RSerial` another client already took.
  RomiSerialClient(std::shared_ptr<IInputStream> in, std::shared_ptr<IOutputStream> out, std::shared_ptr<ILog> log,
                   uint8_t start_id, const std::string& client_name);
  RomiSerialClient(const RomiSerialClient&) = delete;
  RomiSerialClient& operator=(const RomiSerialClient&) = delete;
  /// Closes the port; never blocks on the device.
  ~RomiSerialClient() override;

  /// The id of the last request sent (`start_id` before the first).
  uint8_t id();
  /// Sends `command` and waits for its answer (see the file overview for `response`).
  void send(const char* command, nlohmann::json& response) override;
  /// Logs each request and answer through `log->debug` when on.
  void set_debug(bool value) override;

  /// The text of a Romi code (`tether::romi::describe`).
  static const char* get_error_message(int code);

  /// Tether's client and the port it took; defined in the library.
  struct Session;

 private:
  std::shared_ptr<ILog> log_;
  std::string client_name_;
  std::shared_ptr<RSerial::Link> link_;
  std::unique_ptr<Session> session_;
};

}  // namespace romiserial
