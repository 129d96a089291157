/// @file client.hpp
/// The proxy host client: drives one Arduino "I/O proxy" (servos, digital outputs) over any `ByteStream`
/// with COBS-framed protobuf, in the designed protocol (primary mode) or the deployed variant (compat mode).
///
/// @code
///   auto port = transports::SerialPortStream::open(io.get_executor(), "/dev/ttyACM0", serial_options);
///   proxy::Client client(port);                                  // primary mode: Reset, handshake, pings
///   client.on_event([](const proxy::Event& event) { ... });
///   client.servo(9).init(90);                                        // registered for replay AND sent; blocks
///   client.servo(9).set(120);                                        // throws system_error on failure
///   client.digital(13).async_set(true, [](error_code e, proxy::SendResult r) { ... });
///   std::future<proxy::SendResult> f = client.async_send(message, asio::use_future);   // any ArduinoIn
///
///   proxy::Client old(port2, proxy::Options::compat());     // the deployed firmware
///   old.servo(5).set(180);                                           // completes when written
/// @endcode
///
/// ## Primary mode (the design; `docs/proxy.md`)
/// Wire: `0x00 ‖ COBS(crc16_le ‖ pb) ‖ 0x00` host to device (the leading 0x00 flushes line garbage), device
/// frames `COBS(crc16_le ‖ pb) ‖ 0x00`; pb is one `tether::proxy::ArduinoIn` / `ArduinoOut`.
///   1. **Sends.** Every message gets the next messageId of a 32-bit sequence that starts at a random value
///      (`Options::first_message_id` fixes it), skips 0 and ids in flight. Any `messageId` the caller
///      put in the message is overwritten. At most `kMaxInFlight` (8) messages are in flight; at most one
///      per pin ("lane"), so two commands to the same pin reach the device in submission order even when
///      the first needs re-sends. Messages without a pin (PingFailsafeReset, Ping) have no lane. Being in
///      flight is not all: while a message waits for its ack, the device must not execute 8 other ids (its
///      duplicate filter would forget it and run a re-send again), so a new id goes out only within
///      `kIdWindow` (8) consecutive ids from the anchor of every message in flight (the oldest id in flight
///      when it was sent), pings included. Other messages wait in
///      a FIFO queue on the client's strand.
///   2. **Acks and re-sends.** A message is re-sent, byte for byte (same messageId: the device executes an
///      id once and acks a repeat again), each time an attempt window passes without its ack, until it is
///      acked or its `send_budget` runs out (`ProxyError::timed_out`) or `max_sends` frames were sent. The
///      attempt window is `ProxyTiming::ack_timeout(frame bytes)`: both frames' time on the wire
///      (`(frame + kAckFrameBytes) * bits_per_byte / baud`) plus `processing_margin`, computed for the
///      longest frame in flight (the engine arms every window with one timing), so no message waits less
///      than its own. The budget counts from the first send; queueing is not included. An ack whose id is not
///      in flight (a duplicate ack of a re-sent message, a late ack) is counted in `link.stale` and dropped;
///      acks of pings and Resets are recognised and counted as such, never as stale.
///   3. **Heartbeat.** A `Ping` (its own messageId, fire and forget: the next ping follows) every
///      `ping_period` (1 s), fixed rate (`session::HeartbeatSchedule`), from construction until `close()`.
///   4. **Session** (`session::SessionMonitor`). On construction the client sends `Reset` and waits for
///      `ResetEvent(sessionId)` (Reset re-sent every `session.reset_timeout`, 3 s), stores the id, sends
///      every registered init in registration order, and, once they are all acked, emits
///      `events::SessionEstablished`. Application messages wait in the queue until then (at most
///      `queue_timeout`). A sessionId different from the stored one, in `ArduinoInfo` or in an
///      unsolicited `ResetEvent`, means the device restarted: the client emits `events::ResetDetected`,
///      fails the messages in flight with `ProxyError::device_reset` (whether they ran is unknown), sends
///      `Reset`, waits for the `ResetEvent`, replays every init in order, and emits `SessionEstablished`
///      again: the application does nothing. A replayed init that runs out of budget restarts the
///      handshake (Reset again).
///   5. **Inits.** Every `ServoInit` / `DigitalInit` the client sends (`servo(pin).init(...)`,
///      `digital(pin).init(...)`, or one passed to `async_send`) is registered for replay, keyed by (kind,
///      pin), as soon as the client accepts it, whatever the outcome of that send: registering a key again
///      replaces its message and keeps its place. An init sent while the handshake waits for the
///      `ResetEvent` is not sent twice: it completes when its replay is acked. Inits are never unregistered
///      (the protocol has no "release pin"). At most `kMaxInits`.
///   6. `Reset` cannot be sent with `async_send` (`ProxyError::reserved_message`): it is the handshake's;
///      `restart_session()` resets the device and re-runs the handshake.
///
/// ## Timing (`ProxyTiming`, all in ms; the protocol's values by default)
///   | what | default | rule |
///   |---|---|---|
///   | attempt window | `ack_timeout(frame)`: ~54 ms for a 20-byte frame at 115200 | re-send the same bytes when it passes |
///   | `send_budget` | 1000 | from the first send to the ack (compat: to the frame written); then `ProxyError::timed_out` |
///   | `max_sends` | 255 | frames per message at most (the budget normally ends it first) |
///   | `queue_timeout` | 10000 | before the first send; then `ProxyError::queue_timeout` |
///   | `ping_period` | 1000 | fixed rate; 0 disables (tests) |
///   | `session.reset_timeout` | 3000 | Reset again when no ResetEvent came |
///   | `stale_after` | 5000 | compat: a silent pin is lost |
/// The device side of the design: it fails safe after 10 s without a ping and sends ArduinoInfo every 5 s.
///
/// ## Compatibility mode (the deployed variant, `Options::compat()`)
/// Wire: host `0x00 ‖ COBS(pb) ‖ 0x00`, device `COBS(pb) ‖ 0x00`, no CRC, `RocketryProto` messages, 57600
/// baud (the transport's setting). No messageIds, acks, pings or sessions: a send completes when its frame
/// was written to the stream (`SendResult::acked` is false), or with `ProxyError::timed_out` when the stream
/// took it not within `send_budget` (the device stopped reading; the frame stays queued). Same convenience API; `async_send` takes a
/// `RocketryProto::ArduinoIn` (Reset included). Device messages become events: `EventMessage` ->
/// `events::CompatEvent`, `ErrorMessage` -> `events::CompatError`, `ServoState`/`DigitalState` ->
/// `events::PinReport` (only when a pin reports for the first time, changes value, or comes back after
/// being lost: the device repeats them every ~50 ms), other states -> `events::CompatState`. The deployed
/// host's **staleness rule**: a pin whose state was not refreshed for `stale_after` (5 s) -- counted from
/// its init through this client or its last report -- is reported once with `events::PinLost`, and its
/// `PinStatus::stale` is set until it reports again. With `compat_replay_on_reset` (default) the client
/// re-sends every registered init, in order, when the device announces `EventMessage{RESET}` (its setup
/// ended: a boot, maybe behind the host's back). The deployed host never does this (docs/proxy.md,
/// compatibility table); the deployed firmware ignores an init of a pin it already has, so a replay that
/// races the application's own init changes nothing.
///
/// ## What a send returns
/// Every send completes exactly once with `void(error_code, SendResult)`:
///   | error_code | when |
///   |---|---|
///   | none | primary: the device acked the messageId; compat: the frame was written |
///   | `ProxyError::timed_out` | no ack within `send_budget` (or after `max_sends` frames); compat: the frame not written within `send_budget` (a device that stopped reading) |
///   | `ProxyError::queue_timeout` | not sent within `queue_timeout` (no session, pin busy, id window full) |
///   | `ProxyError::device_reset` | the session changed while it was in flight |
///   | `ProxyError::wrong_mode`, `invalid_message`, `reserved_message`, `message_too_large`, `too_many_inits` | rejected before anything was written |
///   | `asio::error::operation_aborted` | `close()` (or the client's destruction) |
///   | the transport's error (eof, EIO, broken_pipe, ...) | the link failed |
///   | `transports::TransportError::disconnected` | a supervised serial port vanished (in flight, or sent during the outage) |
///
/// When a supervised port is back after an outage the device may have lost power with it: primary runs
/// the handshake of an open (Reset, ResetEvent, every registered init replayed, `SessionEstablished` with
/// `first` false); compat replays the inits (with `compat_replay_on_reset`), as if its RESET had arrived.
///
/// ## Events (`on_event`)
/// Handlers receive an `Event` (a variant; see `events::`). Contract (`client::EventHandlers`, as for
/// every client): called on the client's strand, one event at a time, in arrival order; must not block for
/// long (decoding waits), must not call the blocking API of this client (it fails with
/// `TransportError::would_deadlock`; the async API is fine); exceptions are caught and dropped. Events are
/// not queued for handlers added later.
///
/// ## Threading and lifetime (as `romi::Client`)
///   - All state lives on a strand of the stream's executor; any number of threads may run it and call the
///     client. The client reads continuously from construction on (one read loop, no read deadline; one
///     timer drives the session engine's deadlines, the heartbeat, the queue and the staleness rule; the
///     plumbing is the shared `client::ClientLink`).
///   - Completion handlers run on their associated executor (default: the stream's), never on the client's
///     strand and never inside the initiating call.
///   - The blocking forms need another thread running the executor.
///   - `close()` and the destructor complete every pending send (in flight, queued, or waiting for a
///     replay) with `operation_aborted`, close the stream and never wait for the device. The client owns
///     its stream's reading. `ServoHandle`/`DigitalHandle` keep the implementation alive; after the client
///     is closed their sends complete with `operation_aborted`.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/system/error_code.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "rocketry.pb.h"
#include "tether/core/counters.hpp"
#include "tether/core/session/session_monitor.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/error_category.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/session_policy.hpp"  // SessionPolicy, kMaxInFlight, kAckFrameBytes, ack_timeout
#include "tether/transports/byte_stream.hpp"
#include "tether/client/client_skeleton.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/transports/unique_function.hpp"
#include "tether_proxy.pb.h"

namespace tether::proxy {

/// Error codes of the client (boost::system, like asio).
using error_code = boost::system::error_code;

/// The device remembers the last 8 messageIds it executed (`ProxyDevice::kDuplicateDepth`), pings
/// included. A message re-sent after 8 other ids ran would run again, so while a message is unacked every
/// new id stays within `kIdWindow` consecutive ids of its anchor: the oldest id in flight when it was sent
/// (an older message in flight then may still run for the first time after it). Application messages and
/// pings wait for the window; Reset does not (it clears the filter).
inline constexpr std::uint8_t kIdWindow = 8;
/// Registered inits (ServoInit/DigitalInit keys) at most.
inline constexpr std::uint8_t kMaxInits = 64;
/// Largest protobuf payload sent or accepted; longer device frames are dropped (`link.oversize_frames`).
inline constexpr std::size_t kMaxPayload = 256;

/// Which protocol the client speaks.
enum class Mode : std::uint8_t {
  primary,  ///< The designed protocol: CRC-16, messageIds, acks, pings, sessions (`tether.proxy`).
  compat,   ///< The deployed variant: no CRC, no acks, no ping, no sessions (`RocketryProto`).
};

/// The proxy protocol's handshake: Reset re-sent after 3 s, and a ResetEvent adopted only after the device
/// acked our Reset (it acks before restarting; a boot announcement arriving earlier is not the answer).
inline session::SessionTiming acknowledged_reset_handshake() {
  session::SessionTiming timing;
  timing.require_reset_ack = true;
  return timing;
}

/// All the client's timing. Every duration is in milliseconds; defaults are the protocol's values.
struct ProxyTiming {
  /// Link speed used to compute the ack timeout (the transport sets the real speed). 0 is invalid.
  std::uint32_t baud = 115200;
  /// Bits a byte takes on the wire in the ack-timeout formula (8N1 is 10; 11 leaves a margin). >= 1.
  std::uint32_t bits_per_byte = 11;
  /// Added to the wire time of frame + ack: device processing, OS and USB-serial latency, a device frame
  /// already being sent.
  Duration processing_margin = 50;
  /// Total time from a message's first send to its ack, all re-sends included. >= 1.
  Duration send_budget = 1000;
  /// Frames sent per message at most, the first included (the budget is normally the bound). >= 1.
  std::uint8_t max_sends = 255;
  /// Longest a message waits before its first send (session being set up, its pin busy, 8 in flight).
  Duration queue_timeout = 10000;
  /// Heartbeat period (the protocol: 1000). 0 disables pings (tests; the device then fails safe after 10 s).
  Duration ping_period = 1000;
  /// Reset handshake: Reset is re-sent when no ResetEvent arrives within `session.reset_timeout` (3 s).
  session::SessionTiming session = acknowledged_reset_handshake();
  /// Compat mode: a pin whose state was not refreshed for this long is lost (the deployed host's 5 s).
  Duration stale_after = 5000;

  /// The attempt window of a frame of `frame_bytes`:
  /// `ceil((frame_bytes + kAckFrameBytes) * bits_per_byte * 1000 / baud) + processing_margin`.
  Duration ack_timeout(std::size_t frame_bytes) const;
  /// The fields of the portable ack policy (session_policy.hpp), which computes the engine's timing.
  AckTiming ack_timing() const;
};

/// How a client behaves.
struct Options {
  /// Protocol.
  Mode mode = Mode::primary;
  /// Timing (see `ProxyTiming`).
  ProxyTiming timing;
  /// The first messageId used (the open's Reset gets it); default: a random value. Tests fix it.
  std::optional<std::uint32_t> first_message_id;
  /// Compat mode: re-send every registered init when the device sends `EventMessage{RESET}`.
  bool compat_replay_on_reset = true;
  /// The clock of every deadline (null: the steady clock); tests inject `client::testing::ManualClock`.
  std::shared_ptr<client::LinkClock> clock;

  /// Primary mode with the protocol's timing.
  static Options primary() { return Options(); }
  /// Compatibility mode: the deployed variant at 57600 baud.
  static Options compat() {
    Options options;
    options.mode = Mode::compat;
    options.timing.baud = 57600;
    return options;
  }
};

/// What a send produced (with its error_code; see the file overview).
struct SendResult {
  /// Primary mode: the messageId on the wire (0 when rejected before sending, and in compat mode).
  std::uint32_t message_id = 0;
  /// Frames sent for this message (> 1 after re-sends; 0 when it never reached the wire).
  std::uint8_t attempts = 0;
  /// Primary mode: the device acknowledged it (true exactly when there is no error). Compat: false.
  bool acked = false;
};

/// Completion signature of every asynchronous send.
using SendSignature = void(error_code, SendResult);

/// Kind of pin a report or status concerns.
enum class PinKind : std::uint8_t {
  unknown,  ///< Primary-mode PinState of a pin this client did not init.
  servo,    ///< Servo output (value: position).
  digital,  ///< Digital output (value: 0 or 1).
};

/// Level of a primary-mode device error.
enum class ErrorLevel : std::uint8_t {
  warning,  ///< `Error.Level.WARNING`.
  fatal,    ///< `Error.Level.FATAL`.
};

/// The last known state of a pin (`pin_state`, `pin_states`).
struct PinStatus {
  PinKind kind = PinKind::unknown;  ///< Servo, digital (unknown: primary PinState of a pin not inited here).
  std::uint32_t pin = 0;            ///< Pin number.
  bool has_value = false;           ///< A report arrived (else only the init is known).
  std::int32_t value = 0;           ///< Last reported position / level.
  bool failsafe = false;            ///< Primary: the device drives it to its safe value (failsafe).
  bool stale = false;               ///< Compat: not refreshed for `stale_after` (set until it reports again).
  /// Last report (or its init, before any report) on the client's clock (`Client::now()`, wrap-safe ms:
  /// compare with `tick_difference`), the clock of its deadlines, so a test's manual clock stamps it too.
  Millis updated = 0;
};

/// Events to the application; each type is one alternative of `Event`.
namespace events {
/// Primary: the device sent `Error(text, level)`.
struct DeviceError {
  std::string text;                        ///< The device's text; bytes that are not UTF-8 come as `\xNN`.
  ErrorLevel level = ErrorLevel::warning;  ///< WARNING or FATAL.
};
/// Primary: the device's periodic `ArduinoInfo`, every one. The `ResetDetected` or `FailsafeTriggered` it
/// reveals is emitted just before it.
struct DeviceInfo {
  std::uint32_t session_id = 0;          ///< The device's session.
  bool ping_failsafe_triggered = false;  ///< Its sticky failsafe flag.
};
/// Primary: `pingFailsafeTriggered` became true (once per episode; `reset_failsafe()` clears it).
struct FailsafeTriggered {
  std::uint32_t session_id = 0;  ///< The session it happened in.
};
/// A pin's state: primary `PinState` (every one), compat `ServoState`/`DigitalState` (first, changed, back).
struct PinReport {
  PinKind kind = PinKind::unknown;  ///< From the message (compat) or this client's inits (primary).
  std::uint32_t pin = 0;            ///< Pin number.
  std::int32_t value = 0;           ///< Position (servo) or 0/1 (digital).
  bool failsafe = false;            ///< Primary: driven by the failsafe.
};
/// Compat: a pin not refreshed for `stale_after` (once, until it reports again).
struct PinLost {
  PinKind kind = PinKind::unknown;  ///< Servo or digital.
  std::uint32_t pin = 0;            ///< Pin number.
  Duration silent_ms = 0;           ///< How long it has been silent.
};
/// Primary: the handshake finished: the session id is stored and every registered init was acked.
struct SessionEstablished {
  std::uint32_t session_id = 0;  ///< The device's new session.
  std::size_t inits = 0;         ///< Inits replayed in this handshake.
  bool first = true;             ///< The first session of this client (false after a reset).
};
/// Primary: the device reported another session than the stored one: it restarted. Recovery follows.
struct ResetDetected {
  std::uint32_t previous_session_id = 0;  ///< The stored session.
  /// The id that revealed the restart; 0 when the device revealed it by refusing a message for want of
  /// an init it had acknowledged ("pin N not initialised": its ResetEvent was lost on the line).
  std::uint32_t reported_session_id = 0;
};
/// Compat: the device's `EventMessage` (RESET at the end of its setup, SERVO_CONTROL before acting, ...).
struct CompatEvent {
  RocketryProto::EventTypes type = RocketryProto::RESET;  ///< What happened.
  std::int32_t data = 0;                                  ///< Its data (the pin for control events).
};
/// Compat: the device's `ErrorMessage`.
struct CompatError {
  RocketryProto::ErrorTypes type = RocketryProto::DECODE_ERROR;  ///< What failed.
  std::int32_t data = 0;                                         ///< Its data (the pin for PIN_NOT_INITIALIZED).
};
/// Compat: a DCMotorState, StepperMotorState or LoadCellState, as decoded.
struct CompatState {
  RocketryProto::ArduinoOut message;  ///< The whole message.
};
/// An intact frame whose payload is not a message this client understands (counted too).
struct UndecodableMessage {
  std::string payload;  ///< The payload bytes (CRC already checked in primary mode).
  /// True: the payload is not valid protobuf of the mode's `ArduinoOut` (`undecodable`). False: it is, but
  /// its oneof is unset or unknown to this schema (`unknown_messages`; newer firmware).
  bool malformed = true;
};
/// The link failed (read or write error, EOF): every pending send failed with `error`; the client is done,
/// unless `error` is `disconnected` (a supervised port vanished: the client goes on when it is back).
using LinkFailed = client::LinkFailed;
}  // namespace events

/// Everything a handler can receive.
using Event = std::variant<events::DeviceError, events::DeviceInfo, events::FailsafeTriggered,
                                events::PinReport, events::PinLost, events::SessionEstablished,
                                events::ResetDetected, events::CompatEvent, events::CompatError,
                                events::CompatState, events::UndecodableMessage, events::LinkFailed>;
/// An event handler (contract in the file overview).
using EventHandler = client::EventHandlers<Event>::Handler;
/// Identifies a handler for `Client::remove_event_handler`.
using EventHandlerId = client::EventHandlers<Event>::Id;

/// The client's counters (a snapshot; they only grow).
struct Counters {
  /// Decoder (frames_ok, crc_errors, framing_errors, oversize_frames, resyncs) and session engine (stale
  /// acks, retries = re-sends and unanswered Resets, timeouts, resets = device restarts detected).
  LinkCounters link;
  std::uint32_t undecodable = 0;       ///< Intact frames that are not protobuf of the mode's ArduinoOut.
  std::uint32_t unknown_messages = 0;  ///< Valid protobuf with an unset / unknown oneof.
  std::uint32_t messages_sent = 0;     ///< Application messages and replays sent (first sends).
  std::uint32_t acks = 0;              ///< Acks that completed a message.
  std::uint32_t pings_sent = 0;        ///< Heartbeat pings written.
  std::uint32_t ping_acks = 0;         ///< Acks of pings.
  std::uint32_t resets_sent = 0;       ///< Reset messages written.
  std::uint32_t inits_replayed = 0;    ///< Init messages re-sent by the session (primary) or on RESET (compat).
  std::uint32_t pins_lost = 0;         ///< Compat: PinLost events.
};

/// Where the session stands (`session()`).
struct SessionStatus {
  bool established = false;                ///< Primary: handshake done. Compat: always true.
  std::optional<std::uint32_t> session_id;  ///< Primary: the stored session (from the first ResetEvent on).
};

namespace detail {
class ClientImpl;
/// Type-erased completion handler of a send.
using SendHandler = transports::UniqueFunction<SendSignature>;

/// What the public API asks the implementation to send.
struct Request {
  /// The operation.
  enum class Op : std::uint8_t { raw, servo_init, servo_set, digital_init, digital_set, failsafe_reset };
  Op op = Op::raw;                                                                  ///< What to send.
  std::uint32_t pin = 0;                                                            ///< Convenience ops.
  std::int32_t value = 0;                                                           ///< Convenience ops.
  std::variant<std::monostate, ArduinoIn, RocketryProto::ArduinoIn> message;       ///< `Op::raw`.
};

/// A shared reference to the implementation (`Client` and its pin handles start sends with it).
using ClientRef = client::ClientRef<ClientImpl>;
/// Queues `request` on `impl` as operation `operation` (any thread). Defined in client.cpp.
void start_send(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                SendHandler handler, Request request);
/// Blocking send: failures in `error`.
SendResult blocking_send(const ClientRef& client, Request request, error_code& error);
/// Blocking send: throws `boost::system::system_error`.
SendResult blocking_send(const ClientRef& client, Request request);
/// The pin's status (`ServoHandle::state`, ...).
std::optional<PinStatus> pin_state(const ClientRef& client, PinKind kind, std::uint32_t pin);

/// Starts `request` on `client` with any completion token.
template <typename SendToken>
auto initiate_send(const ClientRef& client, Request request, SendToken&& token) {
  return client.initiate<SendSignature>(std::forward<SendToken>(token), &start_send, std::move(request));
}

inline Request make_request(Request::Op op, std::uint32_t pin, std::int32_t value) {
  Request request;
  request.op = op;
  request.pin = pin;
  request.value = value;
  return request;
}
}  // namespace detail

/// A servo output of one client: `client.servo(9).init(90)`, `.set(120)`. Cheap to copy; keeps the
/// client's implementation alive. Primary: ServoInit{pin, safePosition} / ServoControl{pin, position};
/// compat: the RocketryProto messages of the same names.
class ServoHandle {
 public:
  /// The pin.
  std::uint32_t pin() const { return pin_; }
  /// Registers ServoInit{pin, safe_position} for replay and sends it; completes like a send.
  template <typename SendToken>
  auto async_init(std::int32_t safe_position, SendToken&& token) {
    return detail::initiate_send(client_, request(Op::servo_init, safe_position), std::forward<SendToken>(token));
  }
  /// Blocking `async_init`; failures in `error`.
  SendResult init(std::int32_t safe_position, error_code& error) {
    return detail::blocking_send(client_, request(Op::servo_init, safe_position), error);
  }
  /// Blocking `async_init`; throws `boost::system::system_error`.
  SendResult init(std::int32_t safe_position) {
    return detail::blocking_send(client_, request(Op::servo_init, safe_position));
  }
  /// Sends ServoControl{pin, position}; completes like a send.
  template <typename SendToken>
  auto async_set(std::int32_t position, SendToken&& token) {
    return detail::initiate_send(client_, request(Op::servo_set, position), std::forward<SendToken>(token));
  }
  /// Blocking `async_set`; failures in `error`.
  SendResult set(std::int32_t position, error_code& error) {
    return detail::blocking_send(client_, request(Op::servo_set, position), error);
  }
  /// Blocking `async_set`; throws `boost::system::system_error`.
  SendResult set(std::int32_t position) { return detail::blocking_send(client_, request(Op::servo_set, position)); }
  /// The pin's last known state (none before its init or first report).
  std::optional<PinStatus> state() const { return detail::pin_state(client_, PinKind::servo, pin_); }

 private:
  friend class Client;
  using Op = detail::Request::Op;
  ServoHandle(detail::ClientRef client, std::uint32_t pin) : client_(std::move(client)), pin_(pin) {}
  detail::Request request(Op op, std::int32_t value) const { return detail::make_request(op, pin_, value); }
  detail::ClientRef client_;
  std::uint32_t pin_;
};

/// A digital output of one client: `client.digital(13).init(false)`, `.set(true)`. Primary:
/// DigitalInit{pin, safeState} / DigitalControl{pin, state}; compat: DigitalInit{pin, safeState 0/1} /
/// DigitalControl{pin, activate}.
class DigitalHandle {
 public:
  /// The pin.
  std::uint32_t pin() const { return pin_; }
  /// Registers DigitalInit{pin, safe_state} for replay and sends it; completes like a send.
  template <typename SendToken>
  auto async_init(bool safe_state, SendToken&& token) {
    return detail::initiate_send(client_, request(Op::digital_init, safe_state), std::forward<SendToken>(token));
  }
  /// Blocking `async_init`; failures in `error`.
  SendResult init(bool safe_state, error_code& error) {
    return detail::blocking_send(client_, request(Op::digital_init, safe_state), error);
  }
  /// Blocking `async_init`; throws `boost::system::system_error`.
  SendResult init(bool safe_state) { return detail::blocking_send(client_, request(Op::digital_init, safe_state)); }
  /// Sends DigitalControl{pin, state}; completes like a send.
  template <typename SendToken>
  auto async_set(bool state, SendToken&& token) {
    return detail::initiate_send(client_, request(Op::digital_set, state), std::forward<SendToken>(token));
  }
  /// Blocking `async_set`; failures in `error`.
  SendResult set(bool state, error_code& error) {
    return detail::blocking_send(client_, request(Op::digital_set, state), error);
  }
  /// Blocking `async_set`; throws `boost::system::system_error`.
  SendResult set(bool state) { return detail::blocking_send(client_, request(Op::digital_set, state)); }
  /// The pin's last known state (none before its init or first report).
  std::optional<PinStatus> state() const { return detail::pin_state(client_, PinKind::digital, pin_); }

 private:
  friend class Client;
  using Op = detail::Request::Op;
  DigitalHandle(detail::ClientRef client, std::uint32_t pin) : client_(std::move(client)), pin_(pin) {}
  detail::Request request(Op op, bool value) const { return detail::make_request(op, pin_, value ? 1 : 0); }
  detail::ClientRef client_;
  std::uint32_t pin_;
};

/// Proxy host client for one device. Movable, not copyable (`get_executor`, `close`, `is_open`, `on_event`,
/// `remove_event_handler` and the moves: `client::ClientFront`); see the file overview. `close()`
/// completes every pending send (in flight, queued, or waiting for a replay) with `operation_aborted` and
/// stops reading, pinging and timing (at most the stream's own 250 ms close fallback when no thread runs
/// the executor).
class Client : public client::ClientFront<detail::ClientImpl, Event> {
 public:
  /// Client over `stream`; starts reading at once and, in primary mode, the handshake and the heartbeat.
  /// `handler`, when given, is added (`on_event`) before anything starts, so it sees every event (the
  /// first `SessionEstablished` may come before a handler added after construction). Throws
  /// `std::invalid_argument` for a null stream or invalid timing (baud, bits_per_byte, send_budget or
  /// max_sends of 0).
  explicit Client(std::shared_ptr<transports::ByteStream> stream, const Options& options = Options(),
                  EventHandler handler = EventHandler());

  /// The mode chosen at construction.
  Mode mode() const;

  /// Primary mode: sends `message` (its messageId is assigned) and completes with
  /// `void(error_code, SendResult)` when acked, out of budget, or closed. Any completion token. A handler
  /// made by `client::bind_cancellation` cancels this send alone: queued, it never goes out; in
  /// flight, it completes with `operation_aborted` at once (the device may still run it: its late ack is
  /// stale). A compat send already handed to the stream completes when written.
  template <typename SendToken>
  auto async_send(const ArduinoIn& message, SendToken&& token) {
    return detail::initiate_send(ref(), raw(message), std::forward<SendToken>(token));
  }
  /// Compat mode: sends `message`; completes when written.
  template <typename SendToken>
  auto async_send(const RocketryProto::ArduinoIn& message, SendToken&& token) {
    return detail::initiate_send(ref(), raw(message), std::forward<SendToken>(token));
  }
  /// Blocking send; failures in `error`.
  SendResult send(const ArduinoIn& message, error_code& error) { return detail::blocking_send(ref(), raw(message), error); }
  /// Blocking send; throws `boost::system::system_error`.
  SendResult send(const ArduinoIn& message) { return detail::blocking_send(ref(), raw(message)); }
  /// Blocking compat send; failures in `error`.
  SendResult send(const RocketryProto::ArduinoIn& message, error_code& error) {
    return detail::blocking_send(ref(), raw(message), error);
  }
  /// Blocking compat send; throws `boost::system::system_error`.
  SendResult send(const RocketryProto::ArduinoIn& message) { return detail::blocking_send(ref(), raw(message)); }

  /// The servo on `pin`.
  ServoHandle servo(std::uint32_t pin) const { return ServoHandle(ref(), pin); }
  /// The digital output on `pin`.
  DigitalHandle digital(std::uint32_t pin) const { return DigitalHandle(ref(), pin); }

  /// Primary mode: sends PingFailsafeReset (clears the device's pingFailsafeTriggered); completes like a
  /// send. Compat: `ProxyError::wrong_mode`.
  template <typename SendToken>
  auto async_reset_failsafe(SendToken&& token) {
    return detail::initiate_send(ref(), detail::make_request(detail::Request::Op::failsafe_reset, 0, 0),
                                 std::forward<SendToken>(token));
  }
  /// Blocking `async_reset_failsafe`; throws `boost::system::system_error`.
  SendResult reset_failsafe() {
    return detail::blocking_send(ref(), detail::make_request(detail::Request::Op::failsafe_reset, 0, 0));
  }

  /// Resets the device. Primary: messages in flight fail with `device_reset`, then Reset, ResetEvent, the
  /// inits and `SessionEstablished` as at the start (no `ResetDetected`). Compat: writes `Reset{}`; the
  /// device's `EventMessage{RESET}` then triggers the replay. Any thread; returns at once.
  void restart_session();

  /// Snapshot of the counters. Any thread; updated after each batch of bytes and each completion.
  Counters counters() const;
  /// Where the session stands. Any thread.
  SessionStatus session() const;
  /// The last known state of a pin (inited through this client or reported). Any thread.
  std::optional<PinStatus> pin_state(PinKind kind, std::uint32_t pin) const;
  /// Every known pin, ordered by (kind, pin). Any thread.
  std::vector<PinStatus> pin_states() const;

 private:
  static detail::Request raw(const ArduinoIn& message) {
    detail::Request request;
    request.message = message;
    return request;
  }
  static detail::Request raw(const RocketryProto::ArduinoIn& message) {
    detail::Request request;
    request.message = message;
    return request;
  }
};

}  // namespace tether::proxy
