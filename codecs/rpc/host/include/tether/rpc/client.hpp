/// @file client.hpp
/// The rpc host client: calls a device's methods and receives its streams, for a schema read at run time
/// (schema.hpp), over any `ByteStream`. Requests and replies are protobuf messages of the schema's types
/// (dynamic messages of its pool), or JSON in protobuf's mapping.
///
/// @code
///   auto schema = rpc::Schema::load("arm.proto");
///   rpc::Client arm(port, std::move(schema));
///   arm.wait_ready();                                          // the device answered with the same schema
///   std::string reply = arm.call_json("MoveJoint", R"({"joint": 2, "angleCdeg": -4500})");
///   auto request = arm.new_request("MoveJoint");               // a google::protobuf::Message to fill
///   rpc::CallResult r = arm.call("MoveJoint", *request);       // throws rpc::CallError on a device error
///   rpc::Stream watch = arm.open_stream("Watch", *arm.new_request("Watch"), std::chrono::milliseconds(100),
///       [](const rpc::error_code& e, const rpc::StreamMessage& m) { ... });   // closed when destroyed
/// @endcode
///
/// A program with protoc's classes of the schema uses them directly (`call_as`, `async_call_as`,
/// `open_stream_as`); `tether_generate_rpc` writes a typed client on these (`arm::ArmClient`), whose schema
/// is compiled in (`rpc::Schema(service)`): no .proto is read at run time.
///
/// ## Protocol (tether_rpc.proto; the device side is device/rpc_device.hpp)
///   1. **Session.** From construction the client sends `Hello` (again every `hello_timeout` until
///      answered) and waits for `DeviceHello`. A schema hash other than this schema's is refused:
///      `events::SchemaMismatch`, every pending and later call fails with `RpcError::schema_mismatch` (the
///      client keeps asking: a device reflashed with the right schema is taken). A matching hello stores
///      the device's session and establishes the session (`events::SessionEstablished`): calls wait in a
///      FIFO queue until then (at most `queue_timeout`). A different session in a later `DeviceHello` or
///      an unsolicited `ResetEvent` means the device restarted: `events::ResetDetected`, calls in flight
///      fail with `RpcError::device_reset` (whether they ran is unknown), Hello again, and every open
///      stream is opened again once the session is back: the application does nothing.
///   2. **Calls.** Each call gets the next message id of a 32-bit sequence (random start;
///      `Options::first_message_id` fixes it). The device answers `Reply` or `DeviceError`, then `Ack`.
///      The call's frame is re-sent, byte for byte, each time an attempt window passes without the ack,
///      or at once when the ack came without an answer (the answer was lost: the device sends it again
///      from its cache and runs nothing twice), until answered or `call_budget` runs out
///      (`RpcError::timed_out`). At most `kMaxInFlight` messages are in flight, and a new id goes out only
///      within `kIdWindow` ids of every unacked message's anchor (the device remembers `kIdWindow` ids).
///   3. **Streams.** `open_stream` sends `OpenStream{method, request, period}` (acked like a call); each
///      `StreamMessage` goes to the stream's handler. `close()` (or the handle's destruction) sends
///      `CloseStream`; `close_and_wait` also waits for its ack (before closing the client, or the device
///      streams on until its failsafe). A device error ends the stream (its handler gets it once). One
///      stream per method (the device's rule): opening a method that streams already closes the older
///      stream first (its handler is not called again).
///   4. **Heartbeat.** A `Ping` every `ping_period` (1 s); the device closes its streams after 10 s
///      without one.
///
/// ## What a call returns: `void(error_code, CallResult)`
///   | error_code | when |
///   |---|---|
///   | none | `result.reply` holds the reply |
///   | `RpcError::device_error` | the handler answered an error: `result.device_error` has its code and text |
///   | `RpcError::refused` | the device runtime refused it (code >= 0xFF00 and text in `result.device_error`) |
///   | `RpcError::timed_out`, `queue_timeout`, `device_reset`, `schema_mismatch`, `bad_reply` | see error_category.hpp |
///   | `RpcError::unknown_method`, `wrong_kind`, `invalid_request`, `request_too_large` | rejected before anything was written |
///   | `asio::error::operation_aborted` | `close()` or the client's destruction |
///   | the transport's error | the link failed |
///   | `transports::TransportError::disconnected` | a supervised serial port vanished (in flight, or called during the outage) |
///
/// ## A port that comes back (serial_port_stream.hpp's supervision)
/// During an outage calls fail with `disconnected` at once and the streams stay open (their handlers get
/// nothing). When the port is back the client starts a session as at the open (the device may have lost
/// power with its port): Hello, then every stream opened again on the device, its `seq` from 0.
///
/// ## Events, threading and lifetime: as `proxy::Client` (client_skeleton.hpp's contracts). Stream handlers
/// run on the client's strand like event handlers, under the same contract.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/system/error_code.hpp>
#include <boost/system/system_error.hpp>

#include <chrono>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <typeinfo>
#include <utility>
#include <variant>

#include "tether/core/counters.hpp"
#include "tether/core/session/session_monitor.hpp"
#include "tether/core/time.hpp"
#include "tether/rpc/error_category.hpp"
#include "tether/rpc/schema.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/client/client_skeleton.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/transports/unique_function.hpp"

namespace google::protobuf {
class Descriptor;
class Message;
}

namespace tether::rpc {

/// Error codes of the client (boost::system, like asio).
using error_code = boost::system::error_code;

/// Messages in flight at most (calls, stream opens and closes).
inline constexpr std::uint8_t kMaxInFlight = 4;
/// The device remembers the last 4 message ids it ran (`device::DefaultLimits::kDuplicateDepth`): a new id
/// goes out only within this many ids of the anchor of every unacked message.
inline constexpr std::uint8_t kIdWindow = 4;
/// Largest encoded request (the envelope's bound, tether_rpc.options).
inline constexpr std::size_t kMaxRequestBytes = 64;
/// Largest device payload accepted; longer frames are dropped (`link.oversize_frames`).
inline constexpr std::size_t kMaxPayload = 256;

/// All the client's timing, in milliseconds; defaults are the protocol's.
struct RpcTiming {
  /// Link speed of the attempt window's formula (the transport sets the real speed). > 0.
  std::uint32_t baud = 115200;
  /// Bits a byte takes on the wire in that formula (8N1 is 10; 11 leaves a margin). > 0.
  std::uint32_t bits_per_byte = 11;
  /// Added to the wire time: the handler's run, OS and USB latency. Raise it for slow handlers.
  Duration processing_margin = 50;
  /// From a call's first send to its answer, all re-sends included. > 0.
  Duration call_budget = 2000;
  /// Frames per message at most, the first included. > 0.
  std::uint8_t max_sends = 255;
  /// Longest a call waits before its first send (no session yet, the window full).
  Duration queue_timeout = 10000;
  /// Heartbeat period; 0 disables pings (tests; the device then closes its streams after 10 s).
  Duration ping_period = 1000;
  /// Hello is re-sent when no DeviceHello came within this.
  Duration hello_timeout = 1000;
  /// The attempt window of a request frame of `frame_bytes`: the request, the largest answer and the ack
  /// on the wire (`(frame_bytes + 90) * bits_per_byte * 1000 / baud`, rounded up) plus `processing_margin`.
  Duration attempt_window(std::size_t frame_bytes) const;
};

/// How a client behaves.
struct Options {
  RpcTiming timing;                                  ///< See RpcTiming.
  std::optional<std::uint32_t> first_message_id;    ///< Default: random. Tests fix it.
  std::shared_ptr<client::LinkClock> clock;      ///< Default: the steady clock (tests: ManualClock).
};

/// A device's error answer: a handler's `Status::error(code, text)` or a refusal of the runtime.
struct DeviceError {
  std::uint16_t code = 0;  ///< 1..0xFEFF the application's, 0xFF00 and up Tether's (errors.hpp).
  std::string text;        ///< Its text (bytes that are not UTF-8 come as `\xNN`).
};

/// What a call produced (with its error_code; see the file overview).
struct CallResult {
  /// The reply, a message of the method's output type (null unless the call succeeded).
  std::shared_ptr<google::protobuf::Message> reply;
  /// With `RpcError::device_error` and `refused`: the device's code and text.
  DeviceError device_error;
  /// The message id on the wire (0 when rejected before sending).
  std::uint32_t message_id = 0;
  /// Frames sent for it (> 1 after re-sends).
  std::uint8_t attempts = 0;
};

/// Completion signature of every asynchronous call.
using CallSignature = void(error_code, CallResult);
/// Completion signature of `async_wait_ready`: the device's session.
using ReadySignature = void(error_code, std::uint32_t);

/// What the host adds to a device refusal's text, which the device keeps short: for `bad_request`
/// (errors.hpp) `" (a field over its .options bound?)"`, as a request the schema accepts is refused when a
/// string, bytes or repeated field exceeds the device's nanopb bound; else empty.
std::string_view refusal_hint(std::uint16_t code);

/// The blocking forms' exception for a device's answer (`RpcError::device_error` or `refused`): what() is
/// `"MoveJoint: device error 42: joint 3 is locked"`.
class CallError : public boost::system::system_error {
 public:
  /// The error `code`, the call's method and the device's answer.
  CallError(error_code code, const std::string& method, DeviceError device_error);
  /// The device's code and text.
  const DeviceError& device_error() const { return device_error_; }
  /// `"<method>: device error <code>: <text>"` (`refused` instead of `device error` for a refusal, and
  /// `refusal_hint`'s words after its text).
  const char* what() const noexcept override { return what_.c_str(); }

 private:
  DeviceError device_error_;
  std::string what_;
};

/// One message of a stream, or its end (`StreamHandler`).
struct StreamMessage {
  /// The message (the method's output type); null when the handler is told the stream ended.
  std::shared_ptr<const google::protobuf::Message> message;
  /// Its number in the device's stream (from 0 each time the stream is opened on the device).
  std::uint32_t seq = 0;
  /// When the stream ended with the device's error: its code and text.
  DeviceError device_error;
};

/// A stream's handler. Contract:
///   1. Called on the client's strand, in arrival order, with no error for each message.
///   2. Called once more, with the error, when the stream ends by itself (a device error or refusal, the
///      link failed for good, the client closed, the schema does not match; a supervised port's outage is
///      not an end: the stream comes back with the port); never once `Stream::close()` returned,
///      except a call already running on another thread then (as event handlers, client_skeleton.hpp).
///   3. Must not block for long and must not call the blocking forms of the client; exceptions are caught
///      and dropped.
using StreamHandler = std::function<void(const error_code& error, const StreamMessage& message)>;

namespace detail {
class ClientImpl;
}

/// An open stream: `close()` or the destruction stops it. Movable, not copyable.
class Stream {
 public:
  /// No stream.
  Stream() = default;
  Stream(Stream&& other) noexcept;
  Stream& operator=(Stream&& other) noexcept;
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  /// Closes the stream.
  ~Stream();
  /// Stops the stream (the device is told; its handler is not called again). Idempotent, any thread.
  /// Does not wait: a client closed right after may not have sent the close, and the device then streams
  /// until its failsafe (10 s without a ping).
  void close();
  /// `close()`, then waits until the device acknowledged the close (at most the client's `call_budget` once
  /// sent, as long again for a session to send it in). `error`: none once acknowledged or when nothing runs
  /// on the device (the stream never reached it, ended already, or the device's session ended); else
  /// `RpcError::timed_out`, `queue_timeout` or the link's error. Not on the client's strand (a stream
  /// handler): `would_deadlock`.
  void close_and_wait(error_code& error);
  /// `close_and_wait` giving up after `limit` (`RpcError::timed_out`; the close goes on without a waiter):
  /// for a program that must end soon (Ctrl-C).
  void close_and_wait(error_code& error, std::chrono::milliseconds limit);
  /// True until `close()` or the stream's end.
  bool is_open() const;

 private:
  friend class Client;
  Stream(std::weak_ptr<detail::ClientImpl> client, std::uint64_t key) : client_(std::move(client)), key_(key) {}
  std::weak_ptr<detail::ClientImpl> client_;
  std::uint64_t key_ = 0;
};

/// The device's session as the client knows it.
struct SessionStatus {
  bool established = false;                  ///< The device answered with the same schema; calls go out.
  std::optional<std::uint32_t> session_id;   ///< Its session, once known.
  std::optional<std::uint64_t> device_hash;  ///< The schema hash the device sent last.
};

/// Client diagnostics: the link's counters and the protocol's own. Plain data.
struct Counters {
  LinkCounters link;                     ///< Frames, drops, stale acks, re-sends, timeouts, resets.
  std::uint64_t messages_sent = 0;       ///< Calls, stream opens and closes (first sends).
  std::uint64_t replies = 0;             ///< Calls answered with a reply.
  std::uint64_t device_errors = 0;       ///< Calls and streams answered with a handler's error.
  std::uint64_t refusals = 0;            ///< Messages the device runtime refused.
  std::uint64_t stream_messages = 0;     ///< Stream messages delivered.
  std::uint64_t stale_stream_messages = 0;  ///< Stream messages of no open stream (dropped).
  std::uint64_t pings_sent = 0;          ///< Pings.
  std::uint64_t hellos_sent = 0;         ///< Hellos.
  std::uint64_t undecodable = 0;         ///< Checked frames that were no DeviceMessage.
};

/// Events to the application; each type is one alternative of `Event`.
namespace events {
/// The device answered with this schema; calls go out (again, after a reset).
struct SessionEstablished {
  std::uint32_t session_id = 0;      ///< The device's session.
  std::size_t streams_reopened = 0;  ///< Streams opened again on the device.
  bool first = false;                ///< The first session of this client.
};
/// The device restarted (its session changed).
struct ResetDetected {
  std::uint32_t previous = 0;  ///< The session the client had.
  std::uint32_t current = 0;   ///< The one the device reported.
};
/// The device was built from another schema.
struct SchemaMismatch {
  std::uint64_t device_hash = 0;  ///< What the device sent.
  std::uint64_t schema_hash = 0;  ///< This client's schema.
  std::string text;               ///< `arm.proto: the device's schema is 0x... , this one is 0x...`.
};
/// A DeviceError that belongs to no call or stream (the device could not read a frame).
struct DeviceErrorReport {
  DeviceError error;  ///< Its code and text.
};
/// The link failed (`disconnected`: a supervised port vanished; the client goes on when it is back).
using LinkFailed = client::LinkFailed;
}  // namespace events

/// Everything `on_event` handlers receive.
using Event = std::variant<events::SessionEstablished, events::ResetDetected, events::SchemaMismatch,
                           events::DeviceErrorReport, events::LinkFailed>;

namespace detail {
/// Type-erased completion handler of a call.
using CallHandler = transports::UniqueFunction<CallSignature>;
/// The program's class a typed call wants its reply as: the client makes the reply as one when the
/// method's output is that class's type (a compiled-in schema), in one allocation.
struct TypedReply {
  const google::protobuf::Descriptor* type = nullptr;       ///< The class's type (null: none).
  std::shared_ptr<google::protobuf::Message> (*make)() = nullptr;  ///< A new, empty one.
};
/// `TypedReply` of protoc's class `Reply` (its descriptor looked up once: protoc's accessor runs a
/// `std::call_once` each time).
template <typename Reply>
TypedReply typed_reply() {
  static const google::protobuf::Descriptor* const type = Reply::descriptor();
  return TypedReply{type, [] { return std::shared_ptr<google::protobuf::Message>(std::make_shared<Reply>()); }};
}
/// The replies of a client's typed calls, recycled: each is made as the caller's class once per slot and
/// parsed into again once the caller has let it go (the slot's reference is the only one left), so a
/// warmed-up typed call allocates no reply. Used by one thread at a time (the client's strand).
class TypedReplies {
 public:
  /// A `typed.type` message to parse the reply into: a released one of that class, else a new one (kept
  /// in a free slot for the next calls).
  std::shared_ptr<google::protobuf::Message> take(const TypedReply& typed);

 private:
  struct Slot {
    const google::protobuf::Descriptor* type = nullptr;
    std::shared_ptr<google::protobuf::Message> message;
  };
  // Replies handed over and not yet released: the calls in flight and the completions on their way to
  // their callers; more than this many at once are made and dropped as before.
  std::array<Slot, 8> slots_;
};
/// A call as the public API hands it over: the request is encoded at initiation (its copy: the caller's
/// message may change or go once the initiating function returned), and checked against the schema later.
struct CallRequest {
  std::string method;                                    ///< The method's name.
  std::string request;                                   ///< The request's bytes.
  const google::protobuf::Descriptor* type = nullptr;    ///< The request's type.
  bool encoded = false;                                  ///< False when the request did not serialize.
  TypedReply reply;                                      ///< What the caller takes the reply as.
};
using ClientRef = client::ClientRef<ClientImpl>;
/// Queues `call` on `impl` as operation `operation` (any thread). Defined in client.cpp.
void start_call(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                CallHandler handler, CallRequest call);
/// The call of `method` with `request` as the initiation keeps it; `type` is the request's descriptor when
/// the caller knows it (null: asked from the request).
CallRequest make_call_request(std::string_view method, const google::protobuf::Message& request,
                              TypedReply reply = TypedReply(), const google::protobuf::Descriptor* type = nullptr);
/// `make_call_request` of a typed call: its reply as `Reply`, its request's descriptor from the static type
/// `Request` when that is one of protoc's classes (final: the request is one), looked up once.
template <typename Reply, typename Request>
CallRequest make_typed_call_request(std::string_view method, const Request& request) {
  if constexpr (requires { Request::descriptor(); }) {
    static const google::protobuf::Descriptor* const type = Request::descriptor();
    return make_call_request(method, request, typed_reply<Reply>(), type);
  } else {
    return make_call_request(method, request, typed_reply<Reply>());
  }
}
/// Copies `from` into `to`, a message of the same type from another pool, through its bytes.
void copy_through_bytes(const google::protobuf::Message& from, google::protobuf::Message& to);

/// `message` as `Typed` when it is one, else null. protoc's classes are final: their exact type, compared
/// by `typeid`, is what a `dynamic_cast` would search the hierarchy for.
template <typename Typed, typename Message>
Typed* as_class(Message* message) {
  if constexpr (std::is_final_v<Typed>) {
    return typeid(*message) == typeid(Typed) ? static_cast<Typed*>(message) : nullptr;
  } else {
    return dynamic_cast<Typed*>(message);
  }
}

/// `message` as the program's class `Typed`: moved out when it is one (a compiled-in schema's), copied
/// through its bytes otherwise (a schema read from a file); empty when null.
template <typename Typed>
Typed take_as(const std::shared_ptr<google::protobuf::Message>& message) {
  Typed out;
  if (!message) return out;
  if (Typed* typed = as_class<Typed>(message.get())) {
    out = std::move(*typed);
  } else {
    copy_through_bytes(*message, out);
  }
  return out;
}
}  // namespace detail

/// What a schema mismatch says (the event's text, the blocking wait's error, the bindings'): the schema
/// file and both hashes.
std::string mismatch_text(const Schema& schema, std::uint64_t device_hash);

/// The client; see the file overview.
class Client : public client::ClientFront<detail::ClientImpl, Event> {
 public:
  /// Client of the device behind `stream` (not null) serving `schema`; starts the session at once.
  /// Throws std::invalid_argument for bad timing.
  Client(std::shared_ptr<transports::ByteStream> stream, Schema schema, const Options& options = Options(),
         EventHandler handler = EventHandler());

  /// The schema.
  const Schema& schema() const;

  /// Completes `void(error_code, std::uint32_t session_id)` once the session is established (at once if it
  /// is), or with `RpcError::schema_mismatch` / `queue_timeout` / the link's error.
  template <typename Token>
  auto async_wait_ready(Token&& token) {
    return initiate<ReadySignature>(std::forward<Token>(token), &start_wait_ready);
  }
  /// Blocking `async_wait_ready`; failures in `error`.
  void wait_ready(error_code& error);
  /// Blocking `async_wait_ready`; throws `boost::system::system_error` (its what() names both hashes and
  /// the schema file on a mismatch).
  void wait_ready();

  /// A new, empty request of `method`'s input type. Throws std::invalid_argument for an unknown method.
  std::shared_ptr<google::protobuf::Message> new_request(std::string_view method) const;

  /// Calls `method` with `request` (copied); completes `void(error_code, CallResult)`.
  template <typename Token>
  auto async_call(std::string_view method, const google::protobuf::Message& request, Token&& token) {
    return initiate<CallSignature>(std::forward<Token>(token), &detail::start_call,
                                   detail::make_call_request(method, request));
  }
  /// Blocking call; failures in `error` (a device's answer in `result.device_error`).
  CallResult call(std::string_view method, const google::protobuf::Message& request, error_code& error);
  /// Blocking call; throws `CallError` for a device's answer, `boost::system::system_error` otherwise.
  CallResult call(std::string_view method, const google::protobuf::Message& request);
  /// Blocking call with the request and reply as JSON (protobuf's mapping; every field of the reply
  /// printed). Throws as `call`; a request that does not parse is `RpcError::invalid_request` with the
  /// parser's message.
  std::string call_json(std::string_view method, std::string_view json_request);

  /// Opens a stream of `method` with `request` every `period` (1..65535 ms); `handler` gets its messages.
  /// Throws `boost::system::system_error` for an unknown or unary method, a bad request (`RpcError`) or a
  /// period outside 1..65535 ms (`errc::invalid_argument`).
  Stream open_stream(std::string_view method, const google::protobuf::Message& request,
                     std::chrono::milliseconds period, StreamHandler handler);

  // The typed forms: requests and replies of the program's own protoc classes (what the clients that
  // `tether_generate_rpc` writes call). With a compiled-in schema (`Schema(service)`) the client makes its
  // replies as those classes and hands them over by a move; with a schema read from a file they are
  // copied through their bytes.

  /// Blocking `call` whose reply is a `Reply` (protoc's class of the method's output). Throws as `call`.
  template <typename Reply, typename Request>
  Reply call_as(std::string_view method, const Request& request) {
    static_assert(std::is_base_of_v<google::protobuf::Message, Request>, "a request is a protobuf message");
    return detail::take_as<Reply>(call(detail::make_typed_call_request<Reply>(method, request)).reply);
  }
  /// Blocking `call` whose reply is a `Reply`; failures in `error` (the reply is then empty).
  template <typename Reply, typename Request>
  Reply call_as(std::string_view method, const Request& request, error_code& error) {
    static_assert(std::is_base_of_v<google::protobuf::Message, Request>, "a request is a protobuf message");
    return detail::take_as<Reply>(call(detail::make_typed_call_request<Reply>(method, request), error).reply);
  }
  /// `async_call` completing `void(error_code, Reply)` (an empty `Reply` on failure; a device's code and
  /// text are `async_call`'s `CallResult::device_error`).
  template <typename Reply, typename Request, typename Token>
  auto async_call_as(std::string_view method, const Request& request, Token&& token) {
    static_assert(std::is_base_of_v<google::protobuf::Message, Request>, "a request is a protobuf message");
    return initiate<void(error_code, Reply)>(std::forward<Token>(token), &start_call_as<Reply>,
                                             detail::make_typed_call_request<Reply>(method, request));
  }
  /// `open_stream` whose handler takes each message as a `Typed` (protoc's class of the method's output):
  /// `handler(error, message)` as `StreamHandler`'s contract, with an empty message when the stream ends.
  template <typename Typed>
  Stream open_stream_as(std::string_view method, const google::protobuf::Message& request,
                        std::chrono::milliseconds period,
                        std::function<void(const error_code& error, const Typed& message)> handler) {
    return open_stream(method, request, period,
                       [handler = std::move(handler)](const error_code& error, const StreamMessage& message) {
                         if (!message.message) return handler(error, Typed::default_instance());
                         if (const auto* typed = detail::as_class<const Typed>(message.message.get())) {
                           return handler(error, *typed);
                         }
                         Typed copy;
                         detail::copy_through_bytes(*message.message, copy);
                         handler(error, copy);
                       });
  }

  /// Diagnostics. Any thread.
  Counters counters() const;
  /// The session as the client knows it. Any thread.
  SessionStatus session() const;

 private:
  // The blocking forms of a call as the initiation keeps it.
  CallResult call(detail::CallRequest call, error_code& error);
  CallResult call(detail::CallRequest call);
  static void start_wait_ready(const std::shared_ptr<detail::ClientImpl>& impl,
                               client::ClientLink::OperationId operation,
                               transports::UniqueFunction<ReadySignature> handler);
  template <typename Reply>
  static void start_call_as(const std::shared_ptr<detail::ClientImpl>& impl,
                            client::ClientLink::OperationId operation,
                            transports::UniqueFunction<void(error_code, Reply)> handler, detail::CallRequest call) {
    detail::start_call(impl, operation,
                       detail::CallHandler([handler = std::move(handler)](error_code error, CallResult result) mutable {
                         handler(error, detail::take_as<Reply>(result.reply));
                       }),
                       std::move(call));
  }
};

}  // namespace tether::rpc
