/// @file client.hpp
/// The Romi host client: sends Romi commands to one device over any `ByteStream` and returns its answers.
///
/// @code
///   auto port = transports::SerialPortStream::open(io.get_executor(), "/dev/ttyACM0",
///                                                  transports::SerialOptions::arduino_uno());
///   romi::Client client(port);
///   romi::RomiResponse led = client.call("L[1]");                  // blocking, throws on failure
///   romi::RomiResponse off = client.call({'M', {16}, "Shutdown"});  // built and validated
///   client.async_call("A", [](error_code error, romi::RomiResponse response) { ... });
///   std::future<romi::RomiResponse> f = client.async_call("A", asio::use_future);
///   romi::RomiResponse a = co_await client.async_call("A", asio::use_awaitable);
/// @endcode
///
/// ## What a call returns: error_code or response
/// Every call completes exactly once with `(error_code, RomiResponse)`. The rule is:
///   - **no error_code**: the device answered *this* request with an intact frame (its id, a good CRC).
///     `response.code` is the first value the device sent: 0 success, > 0 an application error
///     (`send_error(101, "...")`), < 0 a protocol error the device found (-16 unknown opcode, -17 bad
///     number of arguments, -4 the device saw our request damaged on every send, ...). The device probably
///     ran the request (except for its protocol errors). Two host codes also arrive this way, because the
///     device did answer: **-26** the answer is not valid JSON (defect B5 of the reference: it threw),
///     **-27** it is JSON but not an array starting with an int16 code, and **-23** it has no array at all;
///     `response.raw` then holds what was received.
///   - **error_code set**: there is no intact answer. `response` still describes the failure
///     (`code`, `values = [code, message]`, `message`), so code that only looks at the response sees it:
///       | error_code | response.code | when |
///       |---|---|---|
///       | tether.romi -24, -14, -8..-13, -22, -32 | same | command rejected before anything was written |
///       | tether.romi -25 (`errc::timed_out`) | -25 | the attempt window or the call budget ran out; `message` says how long the call waited: `client: no reply from the device within 1000 ms` |
///       | tether.romi -1..-6 | same | every answer arrived damaged (host decoder: CRC mismatch, ...) |
///       | `asio::error::operation_aborted` | -33 | `close()` (or the client's destruction) |
///       | the transport's own error (eof, EIO, broken_pipe, ...) | -33 | the link failed |
///
/// ## Timing, retries and stale frames (the session engine, `romi::RequestTable`)
///   1. Each call gets the next 8-bit id (first id 0, like the reference host starting from 255; an id 0
///      that would directly follow a manual call is skipped: the reference firmware remembers the manual
///      call's id 0 and would answer -15 duplicate, defect B6).
///   2. One call is in flight per device; other calls wait in a FIFO queue on the client's strand and
///      start, in order, when the previous one completes. Calls from any number of threads are safe.
///   3. An attempt waits `timing.attempt_timeout` (1 s) for the answer; the whole call never exceeds
///      `timing.call_budget` (2 s), queueing excluded: the budget starts when the frame is sent.
///   4. The same bytes (same id) are sent again, at most `timing.max_attempts` (3) sends in all, only when
///      (a) the device answers an envelope error -1..-6 (it received our frame damaged). Its id may differ
///      from the call's: a request whose id digits were damaged (`#e:5o97`) is answered `#e[-2]:0017`.
///      An envelope error means the device executed nothing, so the re-send is safe whatever the id; but
///      only the call's own answer completes it: once the sends are used up, such an error is stale;
///      (b) a frame from the device arrives damaged while the call is in flight (host decoder error
///      -1..-6: the answer was probably lost; Tether firmware answers a repeated id from its reply cache,
///      defect B3). A damaged log line (`#!...`, or `xxxx` metadata damaged: -7) only re-arms the window;
///      (c) an attempt stays silent and `timing.retry_on_timeout` is set (default off: against the
///      reference firmware a re-send of a request that ran answers -15, and unknown firmware may run it
///      twice; Tether firmware answers it from its reply cache, so configs of Tether devices turn it on).
///      Otherwise a silent attempt times out with -25.
///   5. Log lines (`#!text:xxxx`) are `events::Log` events; frames whose id is not the call's are stale
///      (counted in `LinkCounters::stale`, dropped; envelope errors first re-send, rule 4a), so a late
///      answer or error is never pinned on the wrong request (defect B4). Both re-arm the attempt window,
///      never past the call budget.
///   6. A success or application answer (code >= 0) must also carry the request's opcode; one that does
///      not is stale. Error answers (< 0) may carry another opcode: the reference firmware echoes the last
///      opcode it parsed.
///   7. Responses and log lines up to 1024 bytes are read (the reference host stops at 57: defect B2).
///
/// ## Manual mode
/// `call_manual` sends `#<command>:xxxx\r\n`, the form a human types in a terminal: no id, no CRC check.
/// The device answers with id 00, so the answer is matched by id 00 AND opcode (error answers < 0 with
/// any opcode are accepted, see rule 6). The engine still bounds its time; envelope errors still re-send.
/// A stale answer with id 00 and the same opcode cannot be told apart: use manual mode for debugging only.
///
/// ## Threading and lifetime
///   - All state lives on a strand of the stream's executor; many clients (devices) can share one
///     `io_context` run by any number of threads.
///   - The client reads continuously from construction on (one read loop, no read deadline; one timer
///     drives the engine's deadlines). The plumbing (strand, read loop, write queue, timer, close) is the
///     shared `client::ClientLink`. Bytes that arrive between calls are decoded too: log lines go to
///     the handler, frames count as stale.
///   - Completion handlers run on their associated executor (default: the stream's executor), never on
///     the client's strand and never inside the initiating call.
///   - The blocking forms (`call`, `call_manual`) need another thread running the executor; calling them
///     from a handler on a single-threaded `io_context` deadlocks (the client detects only calls made
///     on its own strand, e.g. from an event handler, and fails them with `TransportError::would_deadlock`).
///   - `close()` and the destructor complete the call in flight and every queued call with
///     `operation_aborted`, close the stream, and never block on the device. The client owns its stream's
///     reading: do not read from the stream yourself while a client uses it.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/system/error_code.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "tether/client/client_skeleton.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/romi/error_category.hpp"
#include "tether/romi/errors.hpp"
#include "tether/romi/response.hpp"
#include "tether/romi/session_policy.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::romi {

/// Error codes of the client (boost::system, like asio).
using error_code = boost::system::error_code;

/// One Romi command, validated when it is made: the payload of a request (`L[1]`, `M[16,"Shutdown"]`).
///
/// Made from a raw string (checked with `validate_request_payload`) or from an opcode, integers and at
/// most one string (checked with `RequestBuilder`). An invalid command keeps its error and is rejected by
/// the client before anything reaches the wire. Errors:
///   -24 empty command; -14 invalid opcode (not `[a-zA-Z0-9?]`); -8 unexpected character; -9 more than
///   12 integers; -10 an integer outside int16; -11 a string over 32 characters; -12 a character outside
///   the allowed string set or an unterminated string; -13 a second string; -32 a reserved character
///   (`#` `:` `"` CR LF); -22 the frame would exceed 64 bytes (payload over 56 characters).
class Command {
 public:
  /// Raw command text, e.g. `L[1]` (implicit, so `client.call("L[1]")` works).
  Command(std::string_view text);  // NOLINT(google-explicit-constructor)
  /// Raw command text from a C string.
  Command(const char* text) : Command(std::string_view(text)) {}  // NOLINT(google-explicit-constructor)
  /// Raw command text from a std::string.
  Command(const std::string& text) : Command(std::string_view(text)) {}  // NOLINT(google-explicit-constructor)
  /// Built command: `opcode`, then `ints` (each in int16 range, at most 12), then `text` as the one string
  /// argument when given: `{'M', {16}, "Shutdown"}` is `M[16,"Shutdown"]`, `{'a'}` is `a`.
  Command(char opcode, const std::vector<std::int32_t>& ints = {},  // NOLINT(google-explicit-constructor)
          std::optional<std::string_view> text = std::nullopt);

  /// True when the command can be sent.
  bool valid() const { return !error_; }
  /// Why it cannot be sent (a "tether.romi" error_code), or success.
  const error_code& error() const { return error_; }
  /// Where in the raw text the error was found (0-based: the offending character, the first character of
  /// a number out of range, the opening quote of a string too long, the text's size when it ends too
  /// early); empty for a valid or built command and for errors of the whole text (empty, too long).
  std::optional<std::size_t> error_offset() const { return error_offset_; }
  /// The error's text for a person, with where it was found: `unexpected char at character 5 (',')`,
  /// `unexpected char at the end (the command is incomplete)`; "" when valid.
  std::string error_text() const;
  /// The payload (opcode + arguments) exactly as it goes on the wire; meaningful only when `valid()`.
  const std::string& payload() const { return payload_; }
  /// The opcode character (first character of the payload; '\0' for an empty command).
  char opcode() const { return payload_.empty() ? '\0' : payload_.front(); }

 private:
  std::string payload_;
  error_code error_;
  std::optional<std::size_t> error_offset_;
};

/// The response a call completes with when `error` ends it without an answer (`values` = `[code,
/// message]`, `opcode` kept): a Romi error keeps its code and text (an invalid `Command`, -25 no answer in
/// time), any other error is -33 with its message. Public so a tool can reject an invalid command before it
/// opens a device and report it exactly as a call would (`tether call`).
RomiResponse failed_response(const error_code& error, char opcode);
/// The response a call with an invalid `command` completes with: its code, and its `error_text()` (where
/// the error is) as the message.
RomiResponse failed_response(const Command& command);

/// How a client behaves; every field has the spec's value by default.
struct Options {
  /// Attempt window (1 s), call budget (2 s), sends per call (3), log lines re-arm the window. Tests and
  /// slow links may change them. `retry_on_timeout` (re-send a silent attempt, rule 4c of the overview):
  /// off by default; turn it on for Tether firmware only (the reference answers a re-send -15).
  session::CallTiming timing = default_call_timing();
  /// Ids start after this one (255: the first call uses id 0, like the reference host).
  std::uint8_t last_id = 255;
  /// The clock of every deadline (null: the steady clock); tests inject `client::testing::ManualClock`.
  std::shared_ptr<client::LinkClock> clock;

  /// Makes `id` the first call's id.
  Options& first_id(std::uint8_t id) {
    last_id = static_cast<std::uint8_t>(id - 1u);
    return *this;
  }
};

/// A random first id for a new host session, 0..254. A new session starting at a fixed id would make its
/// first request look like the previous session's last one sent again to a device that remembers it
/// (Tether firmware answers from its cache, the reference -15); 255 is left out because a fresh reference
/// firmware takes 255 for its last id (defect B6).
std::uint8_t random_first_id();

/// Events to the application; each type is one alternative of `Event`.
namespace events {
/// A log line `#!text:xxxx` from the device (lines between calls too). Without a handler it is dropped.
struct Log {
  std::string text;  ///< The line's text.
};
/// The link failed (the device went away, the port was unplugged): every call in flight and queued
/// completed with `error` first, so an idle client (a shell waiting for input) learns of it too. Once;
/// never for `close()`.
using LinkFailed = client::LinkFailed;
}  // namespace events

/// Everything a handler can receive (`Client::on_event`; contract at `client::EventHandlers`: called
/// on the client's strand in arrival order, must not call the blocking forms of this client, exceptions
/// are caught and dropped).
using Event = std::variant<events::Log, events::LinkFailed>;
/// An event handler (contract at `Event`).
using EventHandler = client::EventHandlers<Event>::Handler;
/// Identifies a handler for `Client::remove_event_handler`.
using EventHandlerId = client::EventHandlers<Event>::Id;

/// Completion signature of every asynchronous call.
using CallSignature = void(error_code, RomiResponse);

namespace detail {
class ClientImpl;
/// Type-erased completion handler of a call.
using CallHandler = transports::UniqueFunction<CallSignature>;
/// Queues `command` on `impl` as operation `operation` (any thread). Defined in client.cpp.
void start_call(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                CallHandler handler, Command command, bool manual);
}  // namespace detail

/// What a client counted: the link's decoder (frames_ok, crc_errors, framing_errors, oversize_frames,
/// resyncs) and session engine (stale, retries, timeouts); the Romi protocol adds nothing of its own.
struct Counters {
  LinkCounters link;  ///< Decoder and engine.
};

/// Romi host client for one device. Movable, not copyable (`get_executor`, `close`, `is_open`, `on_event`,
/// `remove_event_handler` and the moves: `client::ClientFront`); see the file overview. `close()`
/// completes the call in flight and every queued call with `operation_aborted` (at most the stream's own 250 ms close fallback when no
/// thread runs the executor).
class Client : public client::ClientFront<detail::ClientImpl, Event> {
 public:
  /// Client over `stream`; starts reading at once. The stream's executor runs everything. `handler`, when
  /// given, is added (`on_event`) before anything starts, so it sees every event. Throws
  /// `std::invalid_argument` for a null stream.
  explicit Client(std::shared_ptr<transports::ByteStream> stream, const Options& options = Options(),
                  EventHandler handler = EventHandler());

  /// Sends `command` and completes with `void(error_code, RomiResponse)` when the device answered, the
  /// call timed out, or the client was closed. Works with any completion token (callback, `use_future`:
  /// a `std::future<RomiResponse>` that throws `system_error` on an error_code, `use_awaitable`).
  /// An invalid command completes with its error (see `Command`) without touching the wire. A token with a
  /// cancellation slot (`asio::bind_cancellation_slot`) cancels this call alone: queued, it never starts;
  /// in flight, it completes with `operation_aborted` at once and its answer, if it comes, is stale.
  template <typename CallToken>
  auto async_call(Command command, CallToken&& token) {
    return initiate<CallSignature>(std::forward<CallToken>(token), &detail::start_call, std::move(command), false);
  }
  /// `async_call` in manual form (`#command:xxxx\r\n`, answer matched by id 00 and opcode).
  template <typename CallToken>
  auto async_call_manual(Command command, CallToken&& token) {
    return initiate<CallSignature>(std::forward<CallToken>(token), &detail::start_call, std::move(command), true);
  }

  /// Blocking call; failures (see the overview) in `error`, the response always filled in.
  RomiResponse call(const Command& command, error_code& error);
  /// Blocking call; throws `boost::system::system_error` when the error_code is set. An answer with a
  /// non-zero code (application or device error, -26 invalid JSON) is returned, not thrown.
  RomiResponse call(const Command& command);
  /// Blocking built call: `client.call('M', {16}, "Shutdown")`; throws like `call(command)`.
  RomiResponse call(char opcode, const std::vector<std::int32_t>& ints,
                    std::optional<std::string_view> text = std::nullopt) {
    return call(Command(opcode, ints, text));
  }
  /// Blocking manual call; failures in `error`.
  RomiResponse call_manual(const Command& command, error_code& error);
  /// Blocking manual call; throws like `call(command)`.
  RomiResponse call_manual(const Command& command);

  /// Changes the timing of calls that start from now on (calls in flight keep theirs). Any thread.
  void set_timing(const session::CallTiming& timing);

  /// Snapshot of the link counters: decoder (frames_ok, crc_errors, framing_errors, oversize_frames,
  /// resyncs) and engine (stale, retries, timeouts). Any thread; updated after each batch of bytes.
  Counters counters() const;

 private:
  RomiResponse blocking_call(const Command& command, bool manual, error_code& error);
};

}  // namespace tether::romi
