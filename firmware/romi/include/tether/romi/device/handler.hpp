/// @file handler.hpp
/// The handler table of a Romi device: what an application declares, and the interface its handlers
/// reply through. Same names and shapes as the reference RomiSerial library (`IRomiSerial`,
/// `MessageHandler`, `MessageCallback`), so a sketch's table and handlers compile unchanged.
///
/// A table row binds an opcode to a callback and says what the request must carry:
///
///     void handle_led(IRomiSerial* romi, int16_t* args, const char* string_arg);
///     const MessageHandler handlers[] = {
///         {'L', 1, false, handle_led},   // "#L[1]:..." : one integer, no string
///     };
#pragma once

#include <stdint.h>

namespace tether {
namespace romi {
namespace device {

/// The reply side of a device, as a handler sees it.
///
/// Handler contract (the device enforces it; numbers are referred to by the rest of the manual):
///   1. A handler calls exactly ONE of `send_ok()`, `send_error()` or `send()`: that is the response to the
///      request, sent at once, with the request's opcode and id.
///   2. It may call `log()` any number of times before (and after) its reply: each call sends a log frame
///      right away, so log lines reach the host before the response.
///   3. A handler that returns without replying gets the response `[-20]` ("handler sent no reply")
///      from the device.
///   4. Replies after the first one are ignored (not sent) and counted in
///      `DeviceCounters::extra_replies`: one request, one response, the host stays in step.
///      The reference sends every one of them, which desynchronises its host.
///   5. The reply is cached: when the host re-sends the same request (same id, same bytes) because the
///      response was lost or damaged, the device sends the cached response again and does NOT run the
///      handler a second time (exactly-once). Side effects therefore happen once per request.
///   6. A reply whose frame does not fit the device's reply buffer (its `kReplyCapacity`: 72 bytes for
///      `RomiSerial`, `ReplyCapacity` for a `BasicRomiSerial`) is replaced by `[-31]` (reply too long).
///   7. Handlers run inside `handle_input()`; they may take time (the host waits up to 1 s for the
///      response), but they must not call `handle_input()` themselves (such a call returns at once).
///   8. `send_*` or `log` called outside a handler: `log` sends its line (asynchronous logs are allowed by
///      the protocol); `send_*` are ignored and counted as extra replies.
class RomiSerialBase;

/// The methods are not virtual: the device (`RomiSerialBase`, the code of every `RomiSerial` and
/// `BasicRomiSerial`) is the only implementation (a subclass elsewhere does not compile: the constructor
/// is private), so a call goes straight to it and an image links only the replies its handlers use (romi-bench, `send_ok` and `send` only: 1.3 KB less flash than a vtable,
/// which pulled in `send_error`'s number formatting and `log` for every image).
class IRomiSerial {
 public:
  /// Replies `[0]` (success, no values).
  void send_ok();
  /// Replies `[code,"message"]`, or `[code]` when `message` is null. Positive codes belong to the
  /// application, negative ones to the protocol. `message` is sent as is: it must not contain `"`
  /// (no escaping, as in the reference); a ':' is sent as '-' (':' ends a frame's payload on the wire).
  void send_error(int code, const char* message);
  /// Replies with `message`, the complete JSON array text of the response: `"[0,1,2]"`,
  /// `"[0,\"text\"]"`. Its first value must be the code (0 for success). Not validated; ':' is sent as
  /// '-'. A null `message` counts as no reply (contract 3).
  void send(const char* message);
  /// Sends the log frame `#!text:xxxx\r\n` now. CR and LF in `text` are sent as spaces; null is "".
  /// Reference hosts reject log frames longer than 57 characters between '#' and ':' (their defect B2);
  /// Tether hosts accept long ones.
  void log(const char* text);

 private:
  friend class RomiSerialBase;
  IRomiSerial() = default;
  ~IRomiSerial() = default;
};

/// A handler: `romi_serial` to reply through, the integer arguments in request order (exactly the
/// table's `number_arguments` of them; the array holds 12, unused ones are 0), and the string argument
/// (`""` when the row takes none). Both pointers are valid only during the call.
typedef void (*MessageCallback)(IRomiSerial* romi_serial, int16_t* args, const char* string_arg);

/// One row of the handler table.
struct MessageHandler {
  /// The request's opcode: [a-zA-Z0-9?]. The first row with a matching opcode handles the request.
  char opcode;
  /// Integer arguments the request must carry (0..12; the string does not count). Other counts: -17.
  uint8_t number_arguments;
  /// Whether the request must carry one string argument (missing: -18; given when not wanted: -19).
  bool requires_string;
  /// Called with a request that passed every check; see the contract of `IRomiSerial`.
  MessageCallback callback;
};

}  // namespace device
}  // namespace romi
}  // namespace tether
