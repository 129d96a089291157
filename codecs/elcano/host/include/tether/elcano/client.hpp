/// @file client.hpp
/// The Elcano host ring node: the host as one node of a one-way ring of boards, over any `ByteStream`.
///
/// @code
///   auto port = transports::SerialPortStream::open(io.get_executor(), "/dev/ttyUSB0", serial_options);
///   elcano::Options options;
///   options.node.capture = elcano::TypeSet::of(elcano::Type::sensor);   // what the host consumes
///   elcano::RingClient ring(port, options);
///   ring.send(drive);                                                  // blocking, throws on failure
///   elcano::Message segment = ring.request(goal, elcano::Type::segment);  // a goal is answered by a segment
///   elcano::Message sensor = ring.receive(500);                         // within 500 ms
///   ring.async_request(goal, elcano::Type::segment, [](error_code e, elcano::Message reply) { ... });
///   std::future<elcano::Message> f = ring.async_receive(asio::use_future);
/// @endcode
///
/// ## The host in the ring
/// The boards are wired in a one-way ring and the host sits in it like a board: the stream's TX goes to the
/// first board, its RX comes from the last. The client runs the portable `elcano::RingNode` (the code the
/// boards run) on the stream:
///   1. **Capture.** A complete message of a type the host captures is consumed: it completes the request
///      awaiting that type, if one is in flight, else it goes to the receive queue (`async_receive`). The
///      capture set is `Options::node.capture` (`set_capture` changes it) plus, while a request
///      is in flight, its reply type (from its first send until it completes).
///   2. **Forwarding.** Every other message goes on to the first board, in arrival order, without being
///      re-serialised: byte-identical in generation D and for input without whitespace, whitespace-stripped
///      in generation B otherwise (docs/elcano.md). When the node's output queue has no room, the message
///      is dropped and reported (`events::ForwardDropped`).
///   3. **Loop protection.** The node remembers each message it originates for `node.return_timeout`. One
///      that comes back went round the ring without being captured: it is dropped (never forwarded again)
///      and reported once (`events::Undeliverable`); a request fails with it at once
///      (`RingError::undeliverable`), without waiting for its timeout.
///   4. **Pacing.** Everything written to the first board, originated or forwarded, goes through the node's
///      `WritePacer` (`node.pacing`: baud rate, the first board's receive buffer and how often it reads), so
///      the host never writes faster than the first board reads. One write is on the stream at a time; the
///      pacer decides how many bytes it carries.
///   5. **Broken input.** Read errors (bad syntax, bad CRC in generation D, too long) and partial messages
///      older than `node.partial_message_timeout` are dropped, counted and reported
///      (`events::InputDropped`); the reader resynchronises on the next header.
///
/// ## Operations and what they complete with
///   | operation | completes | errors (besides `operation_aborted` on close and the transport's on link failure) |
///   |---|---|---|
///   | `async_send(message)` | `void(error_code)` when the message's last byte was handed to the stream | `invalid_message`, `send_queue_full`, `send_timed_out` |
///   | `async_request(message, reply_type)` | `void(error_code, Message)` with the first captured message of `reply_type` | `invalid_message`, `invalid_reply_type`, `reply_type_busy`, `send_queue_full`, `send_timed_out`, `undeliverable`, `timed_out` |
///   | `async_receive([timeout])` | `void(error_code, Message)` with the next captured message no request claimed | `receive_timed_out` |
/// Every operation completes exactly once. Details:
///   1. **Room.** `originate` answers busy when the node's output queue has no room (it keeps a reserve for
///      forwarding). The client never drops an originated message for that: sends and requests wait, in
///      submission order, in the client's send queue (at most `send_queue_bound`; beyond it they fail at
///      once with `send_queue_full`). A send waits at most `send_timeout` (`send_timed_out`), for room
///      and then for the stream to take its bytes (a device that stopped reading blocks the stream: the
///      bytes stay queued, the send fails at its deadline); a request waits within its call budget and,
///      when its bytes never reached the stream, fails with `send_timed_out` rather than `timed_out`.
///   2. **Requests** use the session engine (`elcano::RequestTable`, one call per reply type: the message
///      carries no id, so the reply is recognised by its type). The call begins when the client accepts
///      it: `timing.attempt_timeout` per attempt, `timing.call_budget` for the whole call including the wait
///      for room, at most `timing.max_attempts` sends; a silent attempt is re-sent
///      (`timing.retry_on_timeout`, true by default: on a ring a lost request and a lost reply look the
///      same, and re-sending a goal or a reading is harmless). Re-sends go before waiting messages. A
///      second request for a reply type already awaited fails with `reply_type_busy`.
///   3. **Receive queue.** Captured messages no request claims wait in a queue of `receive_queue_bound`
///      messages for `async_receive`; when it is full the oldest is dropped, counted
///      (`Counters::receive_overflows`) and reported (`events::ReceiveOverflow`).
///      Receives waiting together are served in the order they were made.
///   4. `close()` (and the destructor) completes every pending operation with `operation_aborted`; a link
///      failure (EOF, unplugged adapter) with the transport's error, after `events::LinkFailed`.
///
/// ## Threading and lifetime (as `romi::Client` and `proxy::Client`)
///   - All state lives on a strand of the stream's executor; any number of threads may run it and call the
///     client. The plumbing (read loop, write queue, one timer for every deadline, close) is the shared
///     `client::ClientLink`. The client reads continuously from construction on: forwarding never
///     waits for the application.
///   - Completion handlers run on their associated executor (default: the stream's), never on the client's
///     strand and never inside the initiating call. The blocking forms need another thread running the
///     executor; called on the client's strand (from an event handler) they fail with
///     `TransportError::would_deadlock`.
///   - `close()` never waits for the device. The client owns its stream's reading and writing.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/system/error_code.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <variant>

#include "tether/client/client_skeleton.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/core/time.hpp"
#include "tether/elcano/error_category.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/elcano/session_policy.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::elcano {

/// Error codes of the client (boost::system, like asio).
using error_code = boost::system::error_code;

/// Longest message the host node reads or originates, `\n` included: the boards' reader capacity. Every
/// message the writer can produce fits (the longest, generation D with six 11-character values, is 89).
inline constexpr std::size_t kMaxMessageBytes = 96;
/// Bytes of the host node's output queue (it holds one less; `RingNode` keeps `kMaxMessageBytes` of it as
/// the forwarding reserve, so originated messages use at most 159).
inline constexpr std::size_t kOutputQueueBytes = 256;
/// Origin records of the host node: messages recognised when they come back, per `return_timeout`.
/// A host originates more than a board; when they are all taken the oldest is overwritten
/// (`RingCounters::origins_evicted`).
inline constexpr std::uint8_t kOriginRecords = 64;

/// How a client behaves. Every duration is in milliseconds.
struct Options {
  /// The host's node: generation, capture set, pacing of the host's link to the first board, partial
  /// message timeout, return timeout (`elcano::RingNodeConfig`).
  RingNodeConfig node;
  /// Timing of requests (`elcano::default_call_timing()`: 500 ms per attempt, 3 sends, 2 s per call,
  /// re-send on a silent attempt). `max_attempts` and `call_budget` must be at least 1.
  session::CallTiming timing = default_call_timing();
  /// Captured messages kept for `async_receive` (at least 1); beyond it the oldest is dropped.
  std::size_t receive_queue_bound = 32;
  /// Sends and requests that may wait for room in the node's output queue (0: none wait; they fail with
  /// `send_queue_full` when the queue is full).
  std::size_t send_queue_bound = 16;
  /// Longest a send waits for room in the node's output queue and for the stream to take its bytes (then
  /// `RingError::send_timed_out`).
  Duration send_timeout = 2000;
  /// The clock of every deadline (null: the steady clock); tests inject `client::testing::ManualClock`.
  std::shared_ptr<client::LinkClock> clock;
};

/// Events to the application (what it should know that is not the completion of one of its
/// operations); each type is one alternative of `Event`.
namespace events {
/// `message`, originated by the host, came back: no node captured it (once per message).
struct Undeliverable {
  Message message;              ///< The message as it came back.
  bool request_failed = false;  ///< A request failed with `RingError::undeliverable` because of it.
};
/// Bytes from the ring were dropped: a reader error kind, or `Error::timed_out` for a partial
/// message past its deadline.
struct InputDropped {
  Error error = Error::success;  ///< Why.
};
/// `message` should have been forwarded but the node's output queue was full.
struct ForwardDropped {
  Message message;  ///< The message dropped.
};
/// `message`, captured, was dropped: the receive queue was full (the oldest goes).
struct ReceiveOverflow {
  Message message;  ///< The message dropped.
};
/// The link failed: every pending operation failed with `error` first.
using LinkFailed = client::LinkFailed;
}  // namespace events

/// Everything a handler can receive (`RingClient::on_event`). Contract (`client::EventHandlers`, as
/// for every client): called on the client's strand, one event at a time, in the order the ring produced
/// them; must not block for long (reading and forwarding wait) and must not call the blocking API of this
/// client (it fails with `TransportError::would_deadlock`); exceptions are caught and dropped (they must
/// not stop the ring); events are not queued for handlers added later.
using Event = std::variant<events::Undeliverable, events::InputDropped, events::ForwardDropped,
                           events::ReceiveOverflow, events::LinkFailed>;
/// An event handler (contract at `Event`).
using EventHandler = client::EventHandlers<Event>::Handler;
/// Identifies a handler for `RingClient::remove_event_handler`.
using EventHandlerId = client::EventHandlers<Event>::Id;

/// The client's counters (a snapshot; they only grow).
struct Counters {
  /// Reader (frames_ok, crc_errors, framing_errors, oversize_frames, resyncs), partial-message deadline
  /// (partial_timeouts) and session engine (retries = re-sends of requests, timeouts).
  LinkCounters link;
  /// The node: captured, forwarded, originated (first sends and re-sends), undeliverable,
  /// queue_full_drops (forwarding), origins_expired, origins_evicted.
  RingCounters ring;
  std::uint32_t replies = 0;            ///< Captured messages that completed a request.
  std::uint32_t receive_overflows = 0;  ///< Captured messages dropped because the receive queue was full.
  std::uint32_t bytes_written = 0;      ///< Bytes handed to the stream (the first board's link).
};

/// Completion signature of `async_send`.
using SendSignature = void(error_code);
/// Completion signature of `async_request` and `async_receive`.
using MessageSignature = void(error_code, Message);

namespace detail {
class RingClientImpl;
/// Type-erased completion handler of a send.
using SendHandler = transports::UniqueFunction<SendSignature>;
/// Type-erased completion handler of a request or a receive.
using MessageHandler = transports::UniqueFunction<MessageSignature>;
/// Names one operation (for its cancellation).
using OperationId = client::ClientLink::OperationId;
/// Queues a send on `impl` (any thread). Defined in client.cpp.
void start_send(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, SendHandler handler,
                const Message& message);
/// Queues a request on `impl` (any thread).
void start_request(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, MessageHandler handler,
                   const Message& message, Type reply_type);
/// Queues a receive on `impl` (any thread); no timeout when `timeout` is empty.
void start_receive(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, MessageHandler handler,
                   std::optional<Duration> timeout);
}  // namespace detail

/// The host's node in an Elcano ring. Movable, not copyable (`get_executor`, `close`, `is_open`,
/// `on_event`, `remove_event_handler` and the moves: `client::ClientFront`); see the file overview.
/// `close()` completes every pending operation with `operation_aborted` and stops reading, forwarding and
/// timing; bytes still in the node's output queue are not written.
///
/// Every asynchronous operation takes any completion token (callback, `use_future`, `use_awaitable`). A
/// handler made by `client::bind_cancellation` cancels that operation alone, with `operation_aborted`:
/// a send or request still waiting for room never goes out; a request in flight stops being re-sent (its
/// late reply goes to the receive queue); a send already handed to the node is written all the same; a
/// receive stops waiting.
class RingClient : public client::ClientFront<detail::RingClientImpl, Event> {
 public:
  /// Client over `stream` (TX to the first board, RX from the last); starts reading and forwarding at
  /// once. `handler`, when given, is added (`on_event`) before anything starts, so it sees every event.
  /// Throws `std::invalid_argument` for a null stream, `timing.max_attempts` or `timing.call_budget` of 0,
  /// or a `receive_queue_bound` of 0.
  explicit RingClient(std::shared_ptr<transports::ByteStream> stream, const Options& options = Options(),
                      EventHandler handler = EventHandler());

  /// Originates `message` and completes with `void(error_code)` once its last byte was handed to the
  /// stream (paced: that may take a while on a slow ring). Any completion token (callback, `use_future`,
  /// `use_awaitable`). Errors: see the file overview.
  template <typename SendToken>
  auto async_send(const Message& message, SendToken&& token) {
    return initiate<SendSignature>(std::forward<SendToken>(token), &detail::start_send, message);
  }
  /// Blocking `async_send`; failures in `error`.
  void send(const Message& message, error_code& error);
  /// Blocking `async_send`; throws `boost::system::system_error`.
  void send(const Message& message);

  /// Originates `message` and completes with `void(error_code, Message)`: the first captured message of
  /// `reply_type` after the first send, or an error (re-sends, timeouts, `undeliverable`: see the file
  /// overview). Any completion token.
  template <typename MessageToken>
  auto async_request(const Message& message, Type reply_type, MessageToken&& token) {
    return initiate<MessageSignature>(std::forward<MessageToken>(token), &detail::start_request, message, reply_type);
  }
  /// Blocking `async_request`; failures in `error` (the returned message is then default-constructed).
  Message request(const Message& message, Type reply_type, error_code& error);
  /// Blocking `async_request`; throws `boost::system::system_error`.
  Message request(const Message& message, Type reply_type);

  /// Completes with `void(error_code, Message)`: the next captured message no request claimed, waiting
  /// for one as long as it takes (until `close()`). Any completion token.
  template <typename MessageToken>
  auto async_receive(MessageToken&& token) {
    return initiate_receive(std::nullopt, std::forward<MessageToken>(token));
  }
  /// `async_receive` that fails with `RingError::receive_timed_out` when no message came within
  /// `timeout` ms (0: only a message already queued).
  template <typename MessageToken>
  auto async_receive(Duration timeout, MessageToken&& token) {
    return initiate_receive(std::optional<Duration>(timeout), std::forward<MessageToken>(token));
  }
  /// Blocking `async_receive(timeout)`; failures in `error`.
  Message receive(Duration timeout, error_code& error);
  /// Blocking `async_receive(timeout)`; throws `boost::system::system_error`.
  Message receive(Duration timeout);

  /// Replaces the configured capture set (the reply types of requests in flight are captured as well).
  /// Applies to messages completed after the change. Any thread.
  void set_capture(TypeSet capture);
  /// The configured capture set. Any thread.
  TypeSet capture() const;

  /// Snapshot of the counters. Any thread; updated after each batch of bytes, each write and each
  /// completion (a caller reading them after a completion sees what led to it).
  Counters counters() const;

 private:
  template <typename MessageToken>
  auto initiate_receive(std::optional<Duration> timeout, MessageToken&& token) {
    return initiate<MessageSignature>(std::forward<MessageToken>(token), &detail::start_receive, timeout);
  }
};

}  // namespace tether::elcano
