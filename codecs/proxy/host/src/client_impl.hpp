// The part of the proxy client both protocols share: the link (a client::ClientLink), the pending
// sends (client::PendingOperations), the registered inits, the pins, the counters and the events.
// The protocols are its two implementations, each in its own file: the designed one (primary_client.cpp:
// ids, acks, session monitor, heartbeat, init replay) and the deployed variant (compat_client.cpp: no CRC,
// a send completes when written, the staleness rule). `Client` picks one by `Options::mode`.
//
// Everything below the public functions runs on the link's strand. All timed work goes through the
// implementation's `pump(now)`, which re-arms the one timer at the earliest deadline.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "tether/client/client_link.hpp"
#include "tether/client/pending_operations.hpp"
#include "tether/proxy/client.hpp"
#include "tether/proxy/decoder.hpp"

namespace tether::proxy::detail {

using PinKey = std::pair<PinKind, std::uint32_t>;
using InitKey = session::SessionMonitor<std::uint32_t, kMaxInits>::InitKey;
using AnyMessage = std::variant<std::monostate, ArduinoIn, RocketryProto::ArduinoIn>;

// `payload` framed: leading 0x00, COBS(crc ‖ payload) (or COBS(payload)), 0x00.
std::shared_ptr<const std::string> frame_of(const std::string& payload, Integrity integrity);
// The wire bytes of either schema's message (empty for none).
std::string serialize(const AnyMessage& message);

// A request turned into a message of the implementation's schema (any thread: depends only on the mode).
struct Built {
  AnyMessage message;
  std::optional<std::uint32_t> lane;  // the pin (primary: one message per pin in flight)
  std::optional<PinKey> init;         // a ServoInit/DigitalInit: registered for replay
  error_code error;
};

// Sets `message` from `request` for the operations both schemas express alike; `digital_set` and
// `failsafe_reset` go to `specific(message, request)`. An error when the request cannot be expressed.
template <typename Message, typename Specific>
error_code fill_message(Request& request, Message& message, Specific&& specific) {
  using Op = Request::Op;
  switch (request.op) {
    case Op::raw:
      if (!std::holds_alternative<Message>(request.message)) return ProxyError::wrong_mode;
      message = std::move(std::get<Message>(request.message));
      return error_code();
    case Op::servo_init:
      message.mutable_servoinit()->set_pin(request.pin);
      message.mutable_servoinit()->set_safeposition(request.value);
      return error_code();
    case Op::servo_set:
      message.mutable_servocontrol()->set_pin(request.pin);
      message.mutable_servocontrol()->set_position(request.value);
      return error_code();
    case Op::digital_init: {
      using SafeState = std::decay_t<decltype(message.digitalinit().safestate())>;  // bool or uint32
      message.mutable_digitalinit()->set_pin(request.pin);
      message.mutable_digitalinit()->set_safestate(static_cast<SafeState>(request.value != 0 ? 1 : 0));
      return error_code();
    }
    case Op::digital_set:
    case Op::failsafe_reset:
      return specific(message, request);
  }
  return error_code();
}

// One send on its way, as the pending-operation queue holds it.
struct Send {
  enum class Stage : std::uint8_t {
    queued,           // primary: waits for the session, its pin, a slot and the id window
    awaiting_replay,  // primary: an init sent during the handshake; completes with its replay's ack
    in_flight,        // primary: sent, waiting for its ack
    writing,          // compat: its frame is queued on the stream
  };
  Stage stage = Stage::queued;
  AnyMessage message;                 // primary: messageId assigned at the first send
  std::optional<std::uint32_t> lane;  // its pin: one message per pin in flight
  std::optional<PinKey> init;         // an init (registered for replay)
  InitKey replay_key = 0;             // != 0: the session's replay of this init (no caller)
  std::uint32_t id = 0;               // messageId on the wire
  std::uint32_t anchor = 0;           // the oldest id in flight when it was first sent (its id if none)
  std::shared_ptr<const std::string> frame;
};
using Sends = client::PendingOperations<SendSignature, Send>;

class ClientImpl : public client::ClientLink {
 public:
  // Starts reading and what the protocol runs from the start (after construction: needs shared_from_this).
  void start();
  Mode mode() const { return options_.mode; }
  // Any thread.
  void submit(OperationId operation, Request request, SendHandler handler);
  // Any thread; returns at once.
  void restart_session();

  client::EventHandlers<Event>& event_handlers() { return events_; }
  Counters counters() const { return published_.get(); }
  SessionStatus session() const { return published_session_.get(); }
  std::optional<PinStatus> pin_state(PinKind kind, std::uint32_t pin) const;
  std::vector<PinStatus> pin_states() const;

 protected:
  // A registered init: its latest message, replayed in registration order.
  struct InitEntry {
    PinKey pin;
    AnyMessage message;
  };
  struct PinEntry {
    PinStatus status;  // `updated` on the link's clock: the staleness rule counts from it
  };

  ClientImpl(std::shared_ptr<transports::ByteStream> stream, const Options& options, Integrity integrity);

  // --- what each protocol defines ---------------------------------------------------------------------

  // The request in this protocol's schema, checked (any thread).
  virtual Built build(Request& request) const = 0;
  // Runs once reading started.
  virtual void on_started(Millis now) = 0;
  // `send` was accepted (its init, if any, registered).
  virtual void on_accepted(Sends::iterator send, Millis now) = 0;
  // The application asked for a new session.
  virtual void restart(Millis now) = 0;
  // One intact frame's payload.
  virtual void on_payload(ByteView payload, Millis now) = 0;
  // Every deadline due at `now`, what can start, then the timer re-armed and the state published.
  virtual void pump(Millis now) = 0;
  // Every pending send ends with `error` (close, link failure).
  virtual void fail_all(const error_code& error) = 0;
  // What `session()` reports.
  virtual SessionStatus session_status() const = 0;
  // The port is back after an outage (the link's `on_link_restored`): the device may have lost power with
  // it, and what it announced at its boot went nowhere, so the protocol starts its recovery itself.
  virtual void on_restored(Millis now) = 0;
  // A new init key is about to be registered; false refuses it (the table of inits is full).
  virtual bool admit_init(InitKey key) {
    (void)key;
    return true;
  }

  // --- shared ----------------------------------------------------------------------------------------

  // Registers (or updates) the init `send` carries. False when the table of inits is full.
  bool register_init(const Send& send, Millis now);
  // Records a report; true when it is news (first value, a change, or the pin back after being lost).
  bool update_pin(PinKind kind, std::uint32_t pin, std::int32_t value, bool failsafe, Millis now);
  // A frame whose payload is no message of the mode's schema (counted and reported).
  void undecodable(ByteView payload, bool malformed);
  // Delivers `event` to every handler, the counters published first (a handler reading them sees what the
  // event reports).
  void emit(const Event& event);
  void publish();

  const Options options_;

  // Strand only.
  Counters counters_;
  Sends sends_;  // in acceptance order
  std::map<InitKey, InitEntry> inits_;
  std::map<PinKey, InitKey> init_keys_;
  std::vector<InitKey> init_order_;

  // Any thread.
  mutable std::mutex mutex_;  // guards pins_
  std::map<PinKey, PinEntry> pins_;

 private:
  void accept(OperationId operation, SendHandler handler, Send send);
  void on_bytes(const std::uint8_t* data, std::size_t size) override;
  void on_link_failed(const error_code& error) override;
  void on_link_restored() override;
  void on_closed() override;
  void on_timer() override { pump(now()); }

  // Strand only.
  Decoder<kMaxPayload> decoder_;
  InitKey next_init_key_ = 1;

  // Any thread.
  client::Published<Counters> published_;
  client::Published<SessionStatus> published_session_;
  client::EventHandlers<Event> events_;
};

// The designed protocol (primary_client.cpp).
std::shared_ptr<ClientImpl> make_primary_client(std::shared_ptr<transports::ByteStream> stream, const Options& options);
// The deployed variant (compat_client.cpp).
std::shared_ptr<ClientImpl> make_compat_client(std::shared_ptr<transports::ByteStream> stream, const Options& options);

}  // namespace tether::proxy::detail
