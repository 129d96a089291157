// Client: the session engine (RequestTable, HeartbeatSchedule, SessionMonitor) driven by the read loop
// and the timer of a transports::ClientLink, like romi::Client (the link owns the strand, the write
// queue, close and the lifetime rules).
//
// Everything below `ClientImpl`'s public functions runs on the link's strand. All timed work goes
// through `pump(now)`: the engine's deadlines (re-sends, timeouts), the session monitor's actions, the
// heartbeat, queue deadlines, starting queued messages and the compat staleness rule; the one timer is
// re-armed at the earliest deadline after every pump.
#include "tether/proxy/client.hpp"

#include <boost/asio/error.hpp>
#include <boost/system/system_error.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <deque>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>

#include "tether/core/session/heartbeat.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/core/wakeup.hpp"
#include "tether/transports/client_link.hpp"

namespace tether::proxy {

namespace asio = boost::asio;
using transports::ByteStream;

AckTiming ProxyTiming::ack_timing() const {
  AckTiming timing;
  timing.baud = baud;
  timing.bits_per_byte = bits_per_byte;
  timing.processing_margin = processing_margin;
  timing.send_budget = send_budget;
  timing.max_sends = max_sends;
  return timing;
}

Duration ProxyTiming::ack_timeout(std::size_t frame_bytes) const { return proxy::ack_timeout(ack_timing(), frame_bytes); }

namespace detail {
namespace {

// ---------------------------------------------------------------------------------------------------------
// Engine types

using Table = RequestTable;  // session_policy.hpp: SessionPolicy, kMaxInFlight
using Monitor = session::SessionMonitor<std::uint32_t, kMaxInits>;
using InitKey = Monitor::InitKey;
using PinKey = std::pair<PinKind, std::uint32_t>;
using AnyMessage = std::variant<std::monostate, ArduinoIn, RocketryProto::ArduinoIn>;

// `payload` framed: leading 0x00, COBS(crc ‖ payload) (or COBS(payload)), 0x00.
std::shared_ptr<const std::string> frame_of(const std::string& payload, Integrity integrity) {
  std::string out(max_frame_size(payload.size()), '\0');
  const Result<size_t> size =
      encode_frame(ByteView::from_chars(payload.data(), payload.size()), integrity, true,
                   MutableByteView(reinterpret_cast<std::uint8_t*>(out.data()), out.size()));
  out.resize(size.ok() ? size.value() : 0);  // the buffer is sized for the worst case: always ok
  return std::make_shared<const std::string>(std::move(out));
}

// ---------------------------------------------------------------------------------------------------------
// Requests -> messages (any thread: depends only on the mode)

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

Built build_primary(Request& request) {
  Built built;
  ArduinoIn message;
  built.error = fill_message(request, message, [](ArduinoIn& in, const Request& r) {
    if (r.op == Request::Op::failsafe_reset) {
      in.mutable_pingfailsafereset();
    } else {
      in.mutable_digitalcontrol()->set_pin(r.pin);
      in.mutable_digitalcontrol()->set_state(r.value != 0);
    }
    return error_code();
  });
  if (built.error) return built;
  switch (message.data_case()) {
    case ArduinoIn::DATA_NOT_SET:
      built.error = ProxyError::invalid_message;
      return built;
    case ArduinoIn::kReset:
      built.error = ProxyError::reserved_message;
      return built;
    case ArduinoIn::kServoInit:
      built.lane = message.servoinit().pin();
      built.init = PinKey(PinKind::servo, message.servoinit().pin());
      break;
    case ArduinoIn::kDigitalInit:
      built.lane = message.digitalinit().pin();
      built.init = PinKey(PinKind::digital, message.digitalinit().pin());
      break;
    case ArduinoIn::kServoControl:
      built.lane = message.servocontrol().pin();
      break;
    case ArduinoIn::kDigitalControl:
      built.lane = message.digitalcontrol().pin();
      break;
    case ArduinoIn::kPing:
    case ArduinoIn::kPingFailsafeReset:
      break;
  }
  message.clear_messageid();
  if (message.ByteSizeLong() + 6 > kMaxPayload) {  // + the largest messageId field
    built.error = ProxyError::message_too_large;
    return built;
  }
  built.message = std::move(message);
  return built;
}

Built build_compat(Request& request) {
  Built built;
  RocketryProto::ArduinoIn message;
  built.error = fill_message(request, message, [](RocketryProto::ArduinoIn& in, const Request& r) {
    if (r.op == Request::Op::failsafe_reset) return error_code(ProxyError::wrong_mode);  // no failsafe flag
    in.mutable_digitalcontrol()->set_pin(r.pin);
    in.mutable_digitalcontrol()->set_activate(r.value != 0);
    return error_code();
  });
  if (built.error) return built;
  switch (message.data_case()) {
    case RocketryProto::ArduinoIn::DATA_NOT_SET:
      built.error = ProxyError::invalid_message;
      return built;
    case RocketryProto::ArduinoIn::kServoInit:
      built.init = PinKey(PinKind::servo, message.servoinit().pin());
      break;
    case RocketryProto::ArduinoIn::kDigitalInit:
      built.init = PinKey(PinKind::digital, message.digitalinit().pin());
      break;
    default:
      break;
  }
  if (message.ByteSizeLong() > kMaxPayload) {
    built.error = ProxyError::message_too_large;
    return built;
  }
  built.message = std::move(message);
  return built;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// The implementation

class ClientImpl final : public transports::ClientLink {
 public:
  ClientImpl(std::shared_ptr<ByteStream> stream, const Options& options)
      : ClientLink(std::move(stream), options.clock),
        options_(options),
        decoder_(options.mode == Mode::primary ? Integrity::crc16 : Integrity::none, counters_.link),
        table_(session::CallTiming(), 0, counters_.link),
        heartbeat_(options.timing.ping_period),
        monitor_(options.timing.session, counters_.link) {
    const std::uint32_t first = options.first_message_id ? *options.first_message_id : std::random_device()();
    last_id_ = first - 1;  // next_id() hands out `first` (0 is skipped)
  }

  // Starts reading and, in primary mode, the handshake and the heartbeat (after construction: it needs
  // shared_from_this).
  void start() {
    post_to_strand([this] {
      start_reading();
      if (primary()) {
        const Millis now = this->now();
        monitor_.start(now);
        if (options_.timing.ping_period > 0) heartbeat_.start(now);
        pump(now);
      }
      publish();
    });
  }

  Mode mode() const { return options_.mode; }

  // Any thread.
  void submit(OperationId operation, Request request, SendHandler handler) {
    Built built = primary() ? build_primary(request) : build_compat(request);
    if (built.error) {
      post_completion(std::move(handler), built.error, SendResult());
      return;
    }
    if (!is_open()) {
      post_completion(std::move(handler), asio::error::operation_aborted, SendResult());
      return;
    }
    auto pending = std::make_unique<Pending>();
    pending->message = std::move(built.message);
    pending->lane = built.lane;
    pending->init = built.init;
    pending->handler = std::move(handler);
    pending->operation = operation;
    post_to_strand([this, pending = std::move(pending)]() mutable { accept(std::move(pending)); });
  }

  void restart_session() {
    post_to_strand([this] {
      if (!is_open() || link_error()) return;
      const Millis now = this->now();
      if (primary()) {
        lose_session();
        monitor_.start(now);
        pump(now);
      } else {
        RocketryProto::ArduinoIn reset;
        reset.mutable_reset();
        write(frame_of(reset.SerializeAsString(), Integrity::none));
        ++counters_.resets_sent;
      }
      publish();
    });
  }

  transports::EventHandlers<Event>& event_handlers() { return events_; }

  Counters counters() const { return published_.get(); }

  SessionStatus session() const { return published_session_.get(); }

  std::optional<PinStatus> pin_state(PinKind kind, std::uint32_t pin) const {
    std::lock_guard lock(mutex_);
    const auto found = pins_.find(PinKey(kind, pin));
    if (found == pins_.end()) return std::nullopt;
    return found->second.status;
  }

  std::vector<PinStatus> pin_states() const {
    std::lock_guard lock(mutex_);
    std::vector<PinStatus> states;
    states.reserve(pins_.size());
    for (const auto& entry : pins_) states.push_back(entry.second.status);
    return states;
  }

 private:
  // One message on its way: queued, waiting for its init's replay, in flight, or (compat) being written.
  struct Pending {
    AnyMessage message;                 // messageId assigned at the first send (primary)
    SendHandler handler;                // empty for replays
    OperationId operation = 0;          // the application's operation (0 for replays)
    std::optional<std::uint32_t> lane;  // its pin: one message per pin in flight
    std::optional<PinKey> init;         // an init (registered for replay)
    InitKey replay_key = 0;             // != 0: the session's replay of this init
    Millis queue_deadline = 0;          // application messages: fail if not sent by then
    std::uint32_t id = 0;               // messageId on the wire
    std::uint32_t anchor = 0;           // the oldest id in flight when it was first sent (its id if none)
    std::shared_ptr<const std::string> frame;
  };
  // Compat: a send whose frame is queued on the stream.
  struct CompatWrite {
    std::uint64_t serial = 0;
    SendHandler handler;  // empty once it timed out
    Millis deadline = 0;  // `send_budget` after acceptance
  };
  // A registered init and the application sends waiting for its replay.
  struct InitEntry {
    PinKey pin;
    AnyMessage message;
    std::vector<std::unique_ptr<Pending>> waiters;
  };
  struct PinEntry {
    PinStatus status;  // `updated` on the link's clock: the staleness rule counts from it
  };
  // A message sent without the table (ping, Reset): its ack is expected and not stale.
  enum class Untracked : std::uint8_t { ping, reset };
  struct UntrackedId {
    std::uint32_t id = 0;
    Untracked kind = Untracked::ping;
    bool used = false;
  };
  bool primary() const { return options_.mode == Mode::primary; }

  // --- accepting sends -------------------------------------------------------------------------------

  void accept(std::unique_ptr<Pending> pending) {
    if (!is_open() || link_error()) {
      const error_code error = link_error() ? link_error() : error_code(asio::error::operation_aborted);
      complete(std::move(pending->handler), error, SendResult());
      return;
    }
    const Millis now = this->now();
    pending->queue_deadline = static_cast<Millis>(now + options_.timing.queue_timeout);
    if (pending->init && !register_init(*pending, now)) {
      complete(std::move(pending->handler), ProxyError::too_many_inits, SendResult());
      return;
    }
    if (!primary()) {
      ++counters_.messages_sent;
      std::shared_ptr<const std::string> frame = frame_of(serialize(pending->message), Integrity::none);
      write_send(std::move(frame), std::move(pending), now);
      pump(now);  // an init starts its pin's staleness clock
      return;
    }
    if (pending->init && monitor_.state() == session::SessionState::awaiting_reset_event) {
      // The replay after the ResetEvent sends it: it completes with its replay's ack.
      inits_.at(init_keys_.at(*pending->init)).waiters.push_back(std::move(pending));
    } else {
      user_queue_.push_back(std::move(pending));
    }
    pump(now);
  }

  // Registers (or updates) the init `pending` carries. False when the table of inits is full.
  bool register_init(const Pending& pending, Millis now) {
    const PinKey pin = *pending.init;
    const auto known = init_keys_.find(pin);
    if (known != init_keys_.end()) {
      inits_.at(known->second).message = pending.message;
      return true;
    }
    if (init_order_.size() >= kMaxInits) return false;
    const InitKey key = next_init_key_++;
    if (primary() && monitor_.register_init(key) != Status::ok) return false;
    init_keys_.emplace(pin, key);
    InitEntry entry;
    entry.pin = pin;
    entry.message = pending.message;
    inits_.emplace(key, std::move(entry));
    init_order_.push_back(key);
    std::lock_guard lock(mutex_);
    auto [it, inserted] = pins_.try_emplace(pin);
    if (inserted) {
      it->second.status.kind = pin.first;
      it->second.status.pin = pin.second;
      it->second.status.updated = now;  // the staleness rule counts from the init
    }
    return true;
  }

  static std::string serialize(const AnyMessage& message) {
    if (const auto* in = std::get_if<ArduinoIn>(&message)) return in->SerializeAsString();
    if (const auto* compat = std::get_if<RocketryProto::ArduinoIn>(&message)) return compat->SerializeAsString();
    return std::string();
  }

  // --- the pump ----------------------------------------------------------------------------------------

  void pump(Millis now) {
    if (!is_open() || link_error()) return;
    if (primary()) {
      for (;;) {
        const Table::Step step = table_.poll(now);
        if (step.action == Table::Action::idle) break;
        if (step.action == Table::Action::resend) {
          const auto found = in_flight_.find(step.id);
          if (found != in_flight_.end()) write(found->second->frame);
        } else {
          on_completion(step.completion, now);
        }
      }
      run_monitor(now);
      if (options_.timing.ping_period > 0 && heartbeat_.due(now) && id_window_open()) {
        send_untracked(Untracked::ping);
        heartbeat_.beat_sent(now);
      }
      expire_waiting(now);
      start_queue(session_queue_, now);
      if (established_) start_queue(user_queue_, now);
    } else {
      expire_compat_writes(now);
      check_stale(now);
    }
    arm_timer();
    publish();
  }

  void run_monitor(Millis now) {
    for (;;) {
      const Monitor::Action action = monitor_.poll(now);
      switch (action.kind) {
        case Monitor::ActionKind::none:
          return;
        case Monitor::ActionKind::send_reset:
          send_untracked(Untracked::reset);
          ++counters_.resets_sent;
          break;
        case Monitor::ActionKind::reset_detected:
          lose_session();
          emit(events::ResetDetected{detected_.first, detected_.second});
          break;
        case Monitor::ActionKind::replay_init: {
          const InitEntry& entry = inits_.at(action.key);
          auto replay = std::make_unique<Pending>();
          replay->message = entry.message;
          replay->lane = entry.pin.second;
          replay->init = entry.pin;
          replay->replay_key = action.key;
          session_queue_.push_back(std::move(replay));
          ++replays_outstanding_;
          ++replayed_this_round_;
          break;
        }
        case Monitor::ActionKind::established:
          monitor_done_ = true;
          maybe_established();
          break;
      }
    }
  }

  void maybe_established() {
    if (!monitor_done_ || replays_outstanding_ != 0 || established_) return;
    established_ = true;
    emit(events::SessionEstablished{monitor_.session_id(), replayed_this_round_, !ever_established_});
    ever_established_ = true;
  }

  // The device's session ended (restart detected, restart requested, a replay unanswered): messages in
  // flight fail with device_reset (replays are dropped: the next round sends them again).
  void lose_session() {
    established_ = false;
    monitor_done_ = false;
    initialised_pins_.clear();
    state_lost_ = false;
    replays_outstanding_ = 0;
    replayed_this_round_ = 0;
    session_queue_.clear();
    std::map<std::uint32_t, std::unique_ptr<Pending>> in_flight = std::move(in_flight_);
    in_flight_.clear();
    lanes_.clear();
    for (auto& [id, pending] : in_flight) {
      const Result<Table::Completion> cancelled = table_.cancel(id);
      if (pending->replay_key != 0) continue;
      SendResult result;
      result.message_id = id;
      result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
      complete(std::move(pending->handler), ProxyError::device_reset, result);
    }
  }

  // --- sending -----------------------------------------------------------------------------------------

  std::uint32_t next_id() {
    last_id_ = peek_next_id();
    return last_id_;
  }
  std::uint32_t peek_next_id() const {
    std::uint32_t id = last_id_;
    do {
      ++id;
    } while (id == 0 || table_.contains(id));
    return id;
  }
  // The oldest id in flight (the one furthest back from the last id sent), or `fallback` when none.
  std::uint32_t oldest_in_flight(std::uint32_t fallback) const {
    std::uint32_t oldest = fallback;
    std::uint32_t oldest_distance = 0;
    for (const auto& entry : in_flight_) {
      const auto distance = static_cast<std::uint32_t>(last_id_ - entry.first);
      if (distance >= oldest_distance) {
        oldest_distance = distance;
        oldest = entry.first;
      }
    }
    return oldest;
  }
  // True when the next id keeps every unacked message in the device's duplicate filter (kIdWindow). After
  // a message X first runs, the device may still run for the first time an older id that was in flight
  // when X was sent (its first copy lost, or still on the way), and the ids sent after X: so every new id
  // stays within kIdWindow of the anchor of each message in flight (the oldest id in flight when it was
  // sent), and at most kIdWindow - 1 other ids run between X and its re-send. Distances in sequence order
  // (ids wrap at 2^32).
  bool id_window_open() const {
    if (in_flight_.empty()) return true;
    std::uint32_t anchor_distance = 0;
    for (const auto& entry : in_flight_) {
      anchor_distance = std::max(anchor_distance, static_cast<std::uint32_t>(last_id_ - entry.second->anchor));
    }
    const std::uint32_t next_distance = anchor_distance + static_cast<std::uint32_t>(peek_next_id() - last_id_);
    return next_distance < kIdWindow;
  }

  // Starts what can start from `queue`, in order, keeping each pin's messages in order.
  void start_queue(std::deque<std::unique_ptr<Pending>>& queue, Millis now) {
    std::set<std::uint32_t> passed;  // pins with a message left behind in this scan
    for (auto it = queue.begin(); it != queue.end();) {
      if (table_.in_flight() >= kMaxInFlight || !id_window_open()) return;
      const std::optional<std::uint32_t> lane = (*it)->lane;
      if (lane && (lanes_.count(*lane) != 0 || passed.count(*lane) != 0)) {
        passed.insert(*lane);
        ++it;
        continue;
      }
      std::unique_ptr<Pending> pending = std::move(*it);
      it = queue.erase(it);
      begin_send(std::move(pending), now);
    }
  }

  void begin_send(std::unique_ptr<Pending> pending, Millis now) {
    const std::uint32_t id = next_id();
    ArduinoIn& message = std::get<ArduinoIn>(pending->message);
    message.set_messageid(id);
    pending->id = id;
    pending->anchor = oldest_in_flight(id);
    pending->frame = frame_of(message.SerializeAsString(), Integrity::crc16);
    refresh_table_timing(pending->frame->size());
    (void)table_.begin_with(id, now);  // a slot is free and the id is not in flight
    if (pending->lane) lanes_.insert(*pending->lane);
    ++counters_.messages_sent;
    if (pending->replay_key != 0) ++counters_.inits_replayed;
    std::shared_ptr<const std::string> frame = pending->frame;
    in_flight_.emplace(id, std::move(pending));
    write(std::move(frame));
  }

  // The table applies its current timing when it arms any attempt window (begin and every re-send), not
  // a per-call one: the window is the ack timeout of the longest frame in flight, so no message gets less
  // than its own `ack_timeout(frame bytes)`.
  void refresh_table_timing(std::size_t starting_frame = 0) {
    std::size_t longest = starting_frame;
    for (const auto& entry : in_flight_) longest = std::max(longest, entry.second->frame->size());
    table_.set_timing(call_timing(options_.timing.ack_timing(), longest));
  }

  void send_untracked(Untracked kind) {
    ArduinoIn message;
    const std::uint32_t id = next_id();
    message.set_messageid(id);
    if (kind == Untracked::ping) {
      message.mutable_ping();
      ++counters_.pings_sent;
    } else {
      message.mutable_reset();
    }
    UntrackedId& slot = untracked_[untracked_next_++ % untracked_.size()];
    slot.id = id;
    slot.kind = kind;
    slot.used = true;
    write(frame_of(message.SerializeAsString(), Integrity::crc16));
  }

  // Ends the message `completion` names (ack, timeout).
  void on_completion(const Table::Completion& completion, Millis now) {
    const auto found = in_flight_.find(completion.id);
    if (found == in_flight_.end()) return;
    std::unique_ptr<Pending> pending = std::move(found->second);
    in_flight_.erase(found);
    if (pending->lane) lanes_.erase(*pending->lane);
    refresh_table_timing();
    SendResult result;
    result.message_id = completion.id;
    result.attempts = completion.attempts;
    result.acked = completion.outcome == session::CallOutcome::ok;
    error_code error;
    switch (completion.outcome) {
      case session::CallOutcome::ok:
        ++counters_.acks;
        if (pending->init) initialised_pins_.insert(pending->init->second);
        break;
      case session::CallOutcome::cancelled:
        error = asio::error::operation_aborted;
        break;
      case session::CallOutcome::timeout:
        error = ProxyError::timed_out;
        break;
      case session::CallOutcome::remote_error:  // the only status an ack carries
        error = ProxyError::refused;
        break;
    }
    if (pending->replay_key == 0) {
      complete(std::move(pending->handler), error, result);
      return;
    }
    // A replayed init the device refuses (a bad pin) was refused to its caller the first time: restarting
    // the session would only have it refused again, forever.
    if (error && error != ProxyError::refused) {
      // The device does not take its inits: start over (Reset, ResetEvent, replay).
      lose_session();
      monitor_.start(now);
      return;
    }
    --replays_outstanding_;
    const auto entry = inits_.find(pending->replay_key);
    if (entry != inits_.end()) {
      // An init sent while the session was being set up waited for this replay: its outcome is theirs
      // (a refused one too: they never saw a refusal of their own).
      for (auto& waiter : entry->second.waiters) complete(std::move(waiter->handler), error, result);
      entry->second.waiters.clear();
    }
    maybe_established();
  }

  // Application messages that waited `queue_timeout` without being sent fail.
  void expire_waiting(Millis now) {
    expire(user_queue_, now);
    for (auto& [key, entry] : inits_) expire(entry.waiters, now);
  }

  // Fails (in order) the messages of `waiting` whose queue deadline passed; the others stay.
  template <typename Container>
  void expire(Container& waiting, Millis now) {
    for (auto it = waiting.begin(); it != waiting.end();) {
      if (tick_reached(now, (*it)->queue_deadline)) {
        complete(std::move((*it)->handler), ProxyError::queue_timeout, SendResult());
        it = waiting.erase(it);
      } else {
        ++it;
      }
    }
  }

  // --- completions -------------------------------------------------------------------------------------

  void fail_all(const error_code& error) {
    std::map<std::uint32_t, std::unique_ptr<Pending>> in_flight = std::move(in_flight_);
    in_flight_.clear();
    lanes_.clear();
    for (auto& [id, pending] : in_flight) {
      const Result<Table::Completion> cancelled = table_.cancel(id);
      SendResult result;
      result.message_id = id;
      result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
      if (pending->handler) complete(std::move(pending->handler), error, result);
    }
    session_queue_.clear();
    replays_outstanding_ = 0;
    for (auto& pending : user_queue_) complete(std::move(pending->handler), error, SendResult());
    user_queue_.clear();
    for (auto& [key, entry] : inits_) {
      for (auto& waiter : entry.waiters) complete(std::move(waiter->handler), error, SendResult());
      entry.waiters.clear();
    }
    abort_writes(error);
    established_ = false;
  }

  // Hands a result to its caller (on the strand); the counters are published first, so a caller reading
  // them after its completion sees its message.
  void complete(SendHandler handler, error_code error, SendResult result) {
    if (!handler) return;
    publish();
    post_completion(std::move(handler), error, result);
  }

  // --- writes ------------------------------------------------------------------------------------------

  // Compat sends: `pending` completes when its frame was written (or could not be), or with `timed_out`
  // when the stream did not take it within `send_budget` (a device that stopped reading). The frame stays
  // queued then (a write cannot be taken back): its entry stays, empty, until the write ends.
  void write_send(std::shared_ptr<const std::string> bytes, std::unique_ptr<Pending> pending, Millis now) {
    const std::uint64_t serial = ++compat_writes_started_;
    compat_writes_.push_back(
        CompatWrite{serial, std::move(pending->handler), static_cast<Millis>(now + options_.timing.send_budget)});
    write(std::move(bytes), [this, serial](error_code error) {
      const auto found = std::find_if(compat_writes_.begin(), compat_writes_.end(),
                                      [serial](const CompatWrite& entry) { return entry.serial == serial; });
      if (found == compat_writes_.end()) return;
      SendResult result;
      if (!error) result.attempts = 1;
      complete(std::move(found->handler), error, result);  // empty when it timed out
      compat_writes_.erase(found);
    });
  }

  // Compat sends whose frame the stream did not take within `send_budget`.
  void expire_compat_writes(Millis now) {
    for (auto& entry : compat_writes_) {
      if (entry.handler && tick_reached(now, entry.deadline)) {
        complete(std::move(entry.handler), ProxyError::timed_out, SendResult());  // leaves it empty
      }
    }
  }

  // --- the link's hooks --------------------------------------------------------------------------------

  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    const Millis now = this->now();
    // A run of bytes per decoder call (its tight COBS + CRC loop) up to each frame; only a frame's
    // handling can close the client or fail the link, so they are checked after each one.
    std::size_t used = 0;
    while (used < size && is_open() && !link_error()) {
      const FeedResult fed = decoder_.feed(ByteView(data + used, size - used));
      used += fed.consumed;
      if (fed.status != DecodeStatus::frame) continue;
      if (primary()) {
        on_primary_payload(decoder_.frame(), now);
      } else {
        on_compat_payload(decoder_.frame(), now);
      }
    }
    pump(now);
  }

  void on_link_failed(const error_code& error) override {
    fail_all(error);
    emit(events::LinkFailed{error});
    publish();
  }

  void on_closed() override {
    fail_all(asio::error::operation_aborted);
    publish();
  }

  void on_timer() override { pump(now()); }

  // The application cancelled one send: queued or waiting for its init's replay, it never goes out; in
  // flight, it leaves the engine (no more re-sends; a late ack is stale) and frees its pin and its slot.
  // A compat send already handed to the stream completes when written (the header says so).
  void on_cancel(OperationId operation) override {
    const error_code aborted = asio::error::operation_aborted;
    const auto matches = [operation](const std::unique_ptr<Pending>& pending) { return pending->operation == operation; };
    if (const auto queued = std::find_if(user_queue_.begin(), user_queue_.end(), matches); queued != user_queue_.end()) {
      complete(std::move((*queued)->handler), aborted, SendResult());
      user_queue_.erase(queued);
      pump(now());
      return;
    }
    for (auto& [key, entry] : inits_) {
      const auto waiting = std::find_if(entry.waiters.begin(), entry.waiters.end(), matches);
      if (waiting == entry.waiters.end()) continue;
      complete(std::move((*waiting)->handler), aborted, SendResult());
      entry.waiters.erase(waiting);
      pump(now());
      return;
    }
    const auto in_flight = std::find_if(in_flight_.begin(), in_flight_.end(),
                                        [&](const auto& entry) { return matches(entry.second); });
    if (in_flight == in_flight_.end()) return;
    const Result<Table::Completion> cancelled = table_.cancel(in_flight->first);
    std::unique_ptr<Pending> pending = std::move(in_flight->second);
    in_flight_.erase(in_flight);
    if (pending->lane) lanes_.erase(*pending->lane);
    refresh_table_timing();
    SendResult result;
    result.message_id = pending->id;
    result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
    complete(std::move(pending->handler), aborted, result);
    pump(now());  // its pin and its slot are free for what waits
  }

  void undecodable(ByteView payload, bool malformed) {
    if (malformed) {
      ++counters_.undecodable;
    } else {
      ++counters_.unknown_messages;
    }
    events::UndecodableMessage event;
    event.payload.assign(reinterpret_cast<const char*>(payload.data()), payload.size());
    event.malformed = malformed;
    emit(event);
  }

  void on_primary_payload(ByteView payload, Millis now) {
    ArduinoOut out;
    if (!parse_device_message(out, payload)) {  // an Error whose text is not UTF-8 is kept, escaped
      undecodable(payload, true);
      return;
    }
    switch (out.data_case()) {
      case ArduinoOut::kAck:
        on_ack(out.ack().messageid(), out.ack().refused(), now);
        return;
      case ArduinoOut::kError:
        emit(events::DeviceError{out.error().text(),
                                 out.error().level() == Error::FATAL ? ErrorLevel::fatal : ErrorLevel::warning});
        state_lost_ = lost_an_init(out.error().text());  // acted on at the refusal's ack
        return;
      case ArduinoOut::kInfo:
        on_info(out.info().sessionid(), out.info().pingfailsafetriggered(), now);
        return;
      case ArduinoOut::kResetEvent:
        on_reset_event(out.resetevent().sessionid(), now);
        return;
      case ArduinoOut::kPinState:
        on_pin_state(out.pinstate(), now);
        return;
      case ArduinoOut::DATA_NOT_SET:
        undecodable(payload, false);
        return;
    }
  }

  void on_ack(std::uint32_t id, bool refused, Millis now) {
    // The device sends a refusal's Error right before its ack: the flag is about this ack only.
    const bool lost = std::exchange(state_lost_, false);
    if (table_.contains(id)) {
      const Table::ReplyResult reply = table_.on_reply(id, refused ? SessionPolicy::kRefused : SessionPolicy::kAcked, now);
      if (reply.verdict == Table::Verdict::completed) on_completion(reply.completion, now);
      if (refused && lost) {
        tell_monitor(0, [&] { monitor_.on_state_lost(now); });  // no id revealed it
        run_monitor(now);
      }
      return;
    }
    for (const UntrackedId& slot : untracked_) {
      if (slot.used && slot.id == id) {
        if (slot.kind == Untracked::ping) ++counters_.ping_acks;
        // The device acks Reset before it restarts: from now on a ResetEvent answers our Reset.
        if (slot.kind == Untracked::reset) monitor_.on_reset_acknowledged(now);
        return;
      }
    }
    (void)table_.on_reply(id, 0, now);  // not in flight: the table counts it stale
  }

  // True when `text` is the device's refusal of a message to a pin it holds no init for ("pin 9 not
  // initialised", proxy_device.hpp rule 6) and the device took that pin's init in this session: it has
  // restarted since, and the ResetEvent that said so was lost (the next ArduinoInfo, up to 5 s later, would
  // be the first to show it). A pin whose init the device refused is not one: nothing was lost.
  bool lost_an_init(const std::string& text) const {
    static constexpr std::string_view kPrefix = "pin ";
    static constexpr std::string_view kSuffix = " not initialised";
    if (monitor_.state() != session::SessionState::established || text.size() <= kPrefix.size() + kSuffix.size() ||
        text.compare(0, kPrefix.size(), kPrefix) != 0 ||
        text.compare(text.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
      return false;
    }
    const char* const last = text.data() + text.size() - kSuffix.size();
    std::uint32_t pin = 0;
    const auto [end, error] = std::from_chars(text.data() + kPrefix.size(), last, pin);
    return error == std::errc() && end == last && initialised_pins_.count(pin) != 0;
  }

  // Hands the monitor an observation (`tell`); a session that ends by it is recorded as detected, the
  // device having reported `reported` (ResetDetected).
  template <typename Tell>
  void tell_monitor(std::uint32_t reported, Tell&& tell) {
    const bool was_in_session = in_session();
    const std::uint32_t stored = monitor_.session_id();
    tell();
    if (was_in_session && !in_session()) detected_ = {stored, reported};
  }

  bool in_session() const {
    return monitor_.state() == session::SessionState::replaying ||
           monitor_.state() == session::SessionState::established;
  }

  void on_info(std::uint32_t session_id, bool failsafe, Millis now) {
    tell_monitor(session_id, [&] { monitor_.on_session_report(session_id, now); });
    run_monitor(now);  // ResetDetected before the report that revealed it; FailsafeTriggered too
    if (failsafe && !failsafe_seen_) emit(events::FailsafeTriggered{session_id});
    failsafe_seen_ = failsafe;
    emit(events::DeviceInfo{session_id, failsafe});
  }

  void on_reset_event(std::uint32_t session_id, Millis now) {
    const bool was_awaiting = monitor_.state() == session::SessionState::awaiting_reset_event;
    tell_monitor(session_id, [&] { monitor_.on_reset_event(session_id, now); });
    if (was_awaiting && in_session()) {  // a new session adopted: a new replay round
      replayed_this_round_ = 0;
      monitor_done_ = false;
      failsafe_seen_ = false;
    }
    run_monitor(now);
  }

  void on_pin_state(const PinState& state, Millis now) {
    PinKind kind = PinKind::unknown;
    if (init_keys_.count(PinKey(PinKind::servo, state.pin())) != 0) {
      kind = PinKind::servo;
    } else if (init_keys_.count(PinKey(PinKind::digital, state.pin())) != 0) {
      kind = PinKind::digital;
    }
    update_pin(kind, state.pin(), state.value(), state.failsafe(), now);
    emit(events::PinReport{kind, state.pin(), state.value(), state.failsafe()});
  }

  // Records a report; true when it is news (first value, a change, or the pin back after being lost).
  bool update_pin(PinKind kind, std::uint32_t pin, std::int32_t value, bool failsafe, Millis now) {
    std::lock_guard lock(mutex_);
    PinEntry& entry = pins_[PinKey(kind, pin)];
    const bool news = !entry.status.has_value || entry.status.value != value || entry.status.stale ||
                      entry.status.failsafe != failsafe;
    entry.status.kind = kind;
    entry.status.pin = pin;
    entry.status.has_value = true;
    entry.status.value = value;
    entry.status.failsafe = failsafe;
    entry.status.stale = false;
    entry.status.updated = now;
    return news;
  }

  void on_compat_payload(ByteView payload, Millis now) {
    RocketryProto::ArduinoOut out;
    if (!out.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
      undecodable(payload, true);
      return;
    }
    switch (out.data_case()) {
      case RocketryProto::ArduinoOut::kEventMessage:
        emit(events::CompatEvent{out.eventmessage().type(), out.eventmessage().data()});
        if (out.eventmessage().type() == RocketryProto::RESET && options_.compat_replay_on_reset) replay_compat();
        return;
      case RocketryProto::ArduinoOut::kErrorMessage:
        emit(events::CompatError{out.errormessage().type(), out.errormessage().data()});
        return;
      case RocketryProto::ArduinoOut::kServoState: {
        const auto& state = out.servostate();
        if (update_pin(PinKind::servo, state.pin(), state.position(), false, now)) {
          emit(events::PinReport{PinKind::servo, state.pin(), state.position(), false});
        }
        return;
      }
      case RocketryProto::ArduinoOut::kDigitalState: {
        const auto& state = out.digitalstate();
        const std::int32_t value = state.activated() ? 1 : 0;
        if (update_pin(PinKind::digital, state.pin(), value, false, now)) {
          emit(events::PinReport{PinKind::digital, state.pin(), value, false});
        }
        return;
      }
      case RocketryProto::ArduinoOut::kDcMotorState:
      case RocketryProto::ArduinoOut::kStepperMotorState:
      case RocketryProto::ArduinoOut::kLoadCellState:
        emit(events::CompatState{out});
        return;
      case RocketryProto::ArduinoOut::DATA_NOT_SET:
        undecodable(payload, false);
        return;
    }
  }

  // Compat: the device ended its setup; every registered init again, in registration order.
  void replay_compat() {
    for (const InitKey key : init_order_) {
      write(frame_of(serialize(inits_.at(key).message), Integrity::none));
      ++counters_.inits_replayed;
    }
  }

  // Compat: pins silent for `stale_after` are lost (once, until they report again).
  void check_stale(Millis now) {
    std::vector<events::PinLost> lost;
    {
      std::lock_guard lock(mutex_);
      for (auto& [key, entry] : pins_) {
        if (entry.status.stale) continue;
        const std::int32_t silent = tick_difference(now, entry.status.updated);
        if (silent >= static_cast<std::int32_t>(options_.timing.stale_after)) {
          entry.status.stale = true;
          lost.push_back(events::PinLost{key.first, key.second, static_cast<Duration>(silent)});
        }
      }
    }
    for (const events::PinLost& event : lost) {
      ++counters_.pins_lost;
      emit(event);
    }
  }

  // --- events ------------------------------------------------------------------------------------------

  // Delivers `event` to every handler. The counters are published first, so a handler (or a thread woken
  // by it) reading them sees what the event reports.
  void emit(const Event& event) {
    publish();
    events_.emit(event);
  }

  // --- deadlines ---------------------------------------------------------------------------------------

  void arm_timer() {
    Deadline wakeup;
    if (primary()) {
      consider(wakeup, table_.next_wakeup());
      consider(wakeup, monitor_.next_wakeup());
      // A ping held back by the id window goes when an ack or a timeout opens it (both pump): no wakeup.
      if (options_.timing.ping_period > 0 && id_window_open()) consider(wakeup, heartbeat_.next());
      for (const auto& pending : user_queue_) consider(wakeup, deadline_at(pending->queue_deadline));
      for (const auto& [key, entry] : inits_) {
        for (const auto& waiter : entry.waiters) consider(wakeup, deadline_at(waiter->queue_deadline));
      }
    } else {
      for (const auto& entry : compat_writes_) {
        if (entry.handler) consider(wakeup, deadline_at(entry.deadline));
      }
      std::lock_guard lock(mutex_);
      for (const auto& [key, entry] : pins_) {
        if (!entry.status.stale) consider(wakeup, deadline_at(static_cast<Millis>(entry.status.updated + options_.timing.stale_after)));
      }
    }
    ClientLink::arm_timer(wakeup);
  }

  void publish() {
    SessionStatus session;
    session.established = primary() ? established_ : !link_error() && is_open();
    session.session_id =
        primary() && monitor_.has_session() ? std::optional<std::uint32_t>(monitor_.session_id()) : std::nullopt;
    published_.set(counters_);
    published_session_.set(session);
  }

  const Options options_;

  // Strand only.
  Counters counters_;
  Decoder<kMaxPayload> decoder_;
  Table table_;
  session::HeartbeatSchedule heartbeat_;
  Monitor monitor_;
  std::uint32_t last_id_ = 0;
  std::array<UntrackedId, 8> untracked_{};
  std::size_t untracked_next_ = 0;
  std::map<std::uint32_t, std::unique_ptr<Pending>> in_flight_;  // by messageId
  std::set<std::uint32_t> lanes_;                                 // pins with a message in flight
  std::deque<std::unique_ptr<Pending>> session_queue_;            // replays: before anything else
  std::deque<std::unique_ptr<Pending>> user_queue_;               // application messages
  std::deque<CompatWrite> compat_writes_;                         // compat: frames queued on the stream
  std::uint64_t compat_writes_started_ = 0;
  std::map<InitKey, InitEntry> inits_;
  std::map<PinKey, InitKey> init_keys_;
  std::vector<InitKey> init_order_;
  InitKey next_init_key_ = 1;
  std::size_t replays_outstanding_ = 0;  // replays queued or in flight in this round
  std::size_t replayed_this_round_ = 0;
  bool monitor_done_ = false;            // the monitor handed out every replay of this round
  bool established_ = false;
  bool ever_established_ = false;
  bool failsafe_seen_ = false;
  std::pair<std::uint32_t, std::uint32_t> detected_{0, 0};  // (stored, reported) of the last reset detected
  std::set<std::uint32_t> initialised_pins_;  // pins whose init the device acked in this session
  bool state_lost_ = false;  // the device refused a message for want of an init it had acked (lost_an_init)

  // Any thread.
  transports::Published<Counters> published_;
  transports::Published<SessionStatus> published_session_;
  mutable std::mutex mutex_;  // guards pins_
  std::map<PinKey, PinEntry> pins_;
  transports::EventHandlers<Event> events_;
};

void start_send(const std::shared_ptr<ClientImpl>& impl, transports::ClientLink::OperationId operation,
                SendHandler handler, Request request) {
  impl->submit(operation, std::move(request), std::move(handler));
}

SendResult blocking_send(const ClientRef& client, Request request, error_code& error) {
  return transports::wait_for_operation<SendResult>(
      *client.link(),
      [&](transports::ClientLink::OperationId operation, SendHandler handler) {
        client.impl()->submit(operation, std::move(request), std::move(handler));
      },
      error);
}

SendResult blocking_send(const ClientRef& client, Request request) {
  return transports::require([&](error_code& error) { return blocking_send(client, std::move(request), error); },
                             "proxy send");
}

std::optional<PinStatus> pin_state(const ClientRef& client, PinKind kind, std::uint32_t pin) {
  return client.impl()->pin_state(kind, pin);
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// Client

namespace {
std::shared_ptr<ByteStream> checked_stream(std::shared_ptr<ByteStream> stream, const Options& options) {
  stream = transports::require_stream(std::move(stream), "proxy::Client");
  const ProxyTiming& timing = options.timing;
  if (timing.baud == 0 || timing.bits_per_byte == 0 || timing.send_budget == 0 || timing.max_sends == 0) {
    throw std::invalid_argument("proxy::Client: baud, bits_per_byte, send_budget and max_sends must be > 0");
  }
  return stream;
}
}  // namespace

Client::Client(std::shared_ptr<ByteStream> stream, const Options& options, EventHandler handler)
    : ClientFront(std::make_shared<detail::ClientImpl>(checked_stream(std::move(stream), options), options)) {
  on_event(std::move(handler));
  impl()->start();
}

Mode Client::mode() const { return impl()->mode(); }
void Client::restart_session() { impl()->restart_session(); }
Counters Client::counters() const { return impl()->counters(); }
SessionStatus Client::session() const { return impl()->session(); }
std::optional<PinStatus> Client::pin_state(PinKind kind, std::uint32_t pin) const {
  return impl()->pin_state(kind, pin);
}
std::vector<PinStatus> Client::pin_states() const { return impl()->pin_states(); }

}  // namespace tether::proxy
