// The proxy client's primary mode: the designed protocol (CRC-16, messageIds, acks and re-sends through
// the session engine's RequestTable, the heartbeat, the SessionMonitor's handshake and init replay). The
// shared part (link, pending sends, inits, pins, events) is client_impl.hpp.
//
// Every send is one entry of the pending-operation queue from acceptance to completion; its stage says
// where it is (queued, waiting for its init's replay, in flight). Replays are the session's own entries
// (no caller). `pump(now)` runs the engine's deadlines, the monitor, the heartbeat, queue deadlines and
// starts what can start; the timer is re-armed at the earliest deadline after every pump.
#include <boost/asio/error.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <memory>
#include <random>
#include <ranges>
#include <set>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>

#include "client_impl.hpp"
#include "tether/core/session/heartbeat.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/client/message_ids.hpp"
#include "tether/core/wakeup.hpp"
#include "tether/proxy/device_message.hpp"

namespace tether::proxy::detail {
namespace {

namespace asio = boost::asio;

class PrimaryClient final : public ClientImpl {
 public:
  PrimaryClient(std::shared_ptr<transports::ByteStream> stream, const Options& options)
      : ClientImpl(std::move(stream), options, Integrity::crc16),
        table_(session::CallTiming(), 0, counters_.link),
        heartbeat_(options.timing.ping_period),
        monitor_(options.timing.session, counters_.link),
        ids_(options.first_message_id ? *options.first_message_id : std::random_device()(), kIdWindow) {
  }

 private:
  using Table = RequestTable;  // session_policy.hpp: SessionPolicy, kMaxInFlight
  using Monitor = session::SessionMonitor<std::uint32_t, kMaxInits>;
  using Stage = Send::Stage;
  // A message sent without the table (ping, Reset): its ack is expected and not stale.
  enum class Untracked : std::uint8_t { ping, reset };
  struct UntrackedId {
    std::uint32_t id = 0;
    Untracked kind = Untracked::ping;
    bool used = false;
  };

  // --- building and accepting sends ---------------------------------------------------------------------

  Built build(Request& request) const override {
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

  void on_started(Millis now) override {
    monitor_.start(now);
    if (options_.timing.ping_period > 0) heartbeat_.start(now);
    pump(now);
  }

  bool admit_init(InitKey key) override { return monitor_.register_init(key) == Status::ok; }

  void on_accepted(Sends::iterator send, Millis now) override {
    send->deadline.arm(now, options_.timing.queue_timeout);
    // An init accepted while the handshake waits for the ResetEvent is not sent twice: the replay after
    // the ResetEvent sends it, and it completes with its replay's ack.
    const bool awaiting_replay = send->state.init && monitor_.state() == session::SessionState::awaiting_reset_event;
    send->state.stage = awaiting_replay ? Stage::awaiting_replay : Stage::queued;
    pump(now);
  }

  void restart(Millis now) override {
    lose_session();
    monitor_.start(now);
    pump(now);
  }

  // Whether or not the device lost power during the outage, the session it had cannot be trusted (a new
  // one's ResetEvent was lost, and the next Info is seconds away): the handshake of an open, inits replayed.
  void on_restored(Millis now) override { restart(now); }

  // --- the pump ----------------------------------------------------------------------------------------

  void pump(Millis now) override {
    if (!is_open() || link_error()) return;
    for (;;) {
      const Table::Step step = table_.poll(now);
      if (step.action == Table::Action::idle) break;
      if (step.action == Table::Action::resend) {
        const auto found = in_flight_.find(step.id);
        if (found != in_flight_.end()) write(found->second->state.frame);
      } else {
        on_completion(step.completion, now);
      }
    }
    run_monitor(now);
    if (options_.timing.ping_period > 0 && heartbeat_.due(now) && id_window_open()) {
      send_untracked(Untracked::ping);
      heartbeat_.beat_sent(now);
    }
    // Application messages that waited `queue_timeout` without being sent fail: queued ones first, then
    // inits waiting for their replay.
    const auto queue_timeout = [](Sends::Operation&) {
      return std::tuple<error_code, SendResult>(ProxyError::queue_timeout, SendResult());
    };
    sends_.expire_if(now, [](const Sends::Operation& send) { return send.state.stage == Stage::queued; }, queue_timeout);
    sends_.expire(now, queue_timeout);
    start_queued(true, now);
    if (established_) start_queued(false, now);
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
          Send replay;
          replay.message = entry.message;
          replay.lane = entry.pin.second;
          replay.init = entry.pin;
          replay.replay_key = action.key;
          sends_.add(0, SendHandler(), std::move(replay));
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
    for (auto it = sends_.begin(); it != sends_.end();) {
      it = it->state.replay_key != 0 && it->state.stage == Stage::queued ? sends_.erase(it) : std::next(it);
    }
    std::map<std::uint32_t, Sends::iterator> in_flight = std::move(in_flight_);
    in_flight_.clear();
    lanes_.clear();
    for (auto& [id, send] : in_flight) {
      const Result<Table::Completion> cancelled = table_.cancel(id);
      if (send->state.replay_key != 0) {
        sends_.erase(send);
        continue;
      }
      SendResult result;
      result.message_id = id;
      result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
      sends_.complete(send, ProxyError::device_reset, result);
    }
  }

  // --- sending -----------------------------------------------------------------------------------------

  std::uint32_t next_id() {
    return ids_.next([this](std::uint32_t id) { return table_.contains(id); });
  }
  // The ids in flight and their anchors (message_ids.hpp: the device's duplicate filter keeps each unacked
  // message while every new id stays within kIdWindow of its anchor).
  auto in_flight_ids() const { return in_flight_ | std::views::keys; }
  bool id_window_open() const {
    return ids_.window_open(in_flight_ | std::views::transform([](const auto& entry) { return entry.second->state.anchor; }),
                            [this](std::uint32_t id) { return table_.contains(id); });
  }

  // Starts what can start of the session's replays (`replays`) or of the application's messages, in
  // order, keeping each pin's messages in order.
  void start_queued(bool replays, Millis now) {
    std::set<std::uint32_t> passed;  // pins with a message left behind in this scan
    for (auto it = sends_.begin(); it != sends_.end(); ++it) {
      if (it->state.stage != Stage::queued || (it->state.replay_key != 0) != replays) continue;
      if (table_.in_flight() >= kMaxInFlight || !id_window_open()) return;
      const std::optional<std::uint32_t> lane = it->state.lane;
      if (lane && (lanes_.count(*lane) != 0 || passed.count(*lane) != 0)) {
        passed.insert(*lane);
        continue;
      }
      begin_send(it, now);
    }
  }

  void begin_send(Sends::iterator send, Millis now) {
    const std::uint32_t id = next_id();
    ArduinoIn& message = std::get<ArduinoIn>(send->state.message);
    message.set_messageid(id);
    send->state.stage = Stage::in_flight;
    send->deadline.disarm();  // the engine's budget from now on
    send->state.id = id;
    send->state.anchor = ids_.anchor(id, in_flight_ids());
    send->state.frame = frame_of(message.SerializeAsString(), Integrity::crc16);
    refresh_table_timing(send->state.frame->size());
    (void)table_.begin_with(id, now);  // a slot is free and the id is not in flight
    if (send->state.lane) lanes_.insert(*send->state.lane);
    ++counters_.messages_sent;
    if (send->state.replay_key != 0) ++counters_.inits_replayed;
    in_flight_.emplace(id, send);
    write(send->state.frame);
  }

  // The table applies its current timing when it arms any attempt window (begin and every re-send), not
  // a per-call one: the window is the ack timeout of the longest frame in flight, so no message gets less
  // than its own `ack_timeout(frame bytes)`.
  void refresh_table_timing(std::size_t starting_frame = 0) {
    std::size_t longest = starting_frame;
    for (const auto& entry : in_flight_) longest = std::max(longest, entry.second->state.frame->size());
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
    const Sends::iterator send = found->second;
    in_flight_.erase(found);
    if (send->state.lane) lanes_.erase(*send->state.lane);
    refresh_table_timing();
    SendResult result;
    result.message_id = completion.id;
    result.attempts = completion.attempts;
    result.acked = completion.outcome == session::CallOutcome::ok;
    error_code error;
    switch (completion.outcome) {
      case session::CallOutcome::ok:
        ++counters_.acks;
        if (send->state.init) initialised_pins_.insert(send->state.init->second);
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
    const InitKey replay_key = send->state.replay_key;
    if (replay_key == 0) {
      sends_.complete(send, error, result);
      return;
    }
    sends_.erase(send);  // the session's own: no caller
    // A replayed init the device refuses (a bad pin) was refused to its caller the first time: restarting
    // the session would only have it refused again, forever.
    if (error && error != ProxyError::refused) {
      // The device does not take its inits: start over (Reset, ResetEvent, replay).
      lose_session();
      monitor_.start(now);
      return;
    }
    --replays_outstanding_;
    // An init sent while the session was being set up waited for this replay: its outcome is theirs (a
    // refused one too: they never saw a refusal of their own).
    for (auto it = sends_.begin(); it != sends_.end();) {
      const bool waiter = it->state.stage == Stage::awaiting_replay && init_keys_.at(*it->state.init) == replay_key;
      it = waiter ? sends_.complete(it, error, result) : std::next(it);
    }
    maybe_established();
  }

  // --- completions -------------------------------------------------------------------------------------

  void fail_all(const error_code& error) override {
    sends_.fail_all([&](Sends::Operation& send) {
      SendResult result;
      if (send.state.stage == Stage::in_flight) {
        const Result<Table::Completion> cancelled = table_.cancel(send.state.id);
        result.message_id = send.state.id;
        result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
      }
      return std::tuple<error_code, SendResult>(error, result);
    });
    in_flight_.clear();
    lanes_.clear();
    replays_outstanding_ = 0;
    abort_writes(error);
    established_ = false;
  }

  // The application cancelled one send: queued or waiting for its init's replay, it never goes out; in
  // flight, it leaves the engine (no more re-sends; a late ack is stale) and frees its pin and its slot.
  void on_cancel(OperationId operation) override {
    const bool cancelled = sends_.cancel(operation, [&](Sends::Operation& send) {
      SendResult result;
      if (send.state.stage == Stage::in_flight) {
        const Result<Table::Completion> ended = table_.cancel(send.state.id);
        in_flight_.erase(send.state.id);
        if (send.state.lane) lanes_.erase(*send.state.lane);
        refresh_table_timing();
        result.message_id = send.state.id;
        result.attempts = ended.ok() ? ended.value().attempts : 0;
      }
      return std::tuple<error_code, SendResult>(asio::error::operation_aborted, result);
    });
    if (cancelled) pump(now());  // its pin and its slot are free for what waits
  }

  // --- the device's messages ---------------------------------------------------------------------------

  void on_payload(ByteView payload, Millis now) override {
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

  // --- deadlines and state ----------------------------------------------------------------------------

  void arm_timer() {
    Deadline wakeup = sends_.next_deadline();  // queued messages and inits waiting for their replay
    consider(wakeup, table_.next_wakeup());
    consider(wakeup, monitor_.next_wakeup());
    // A ping held back by the id window goes when an ack or a timeout opens it (both pump): no wakeup.
    if (options_.timing.ping_period > 0 && id_window_open()) consider(wakeup, heartbeat_.next());
    ClientLink::arm_timer(wakeup);
  }

  SessionStatus session_status() const override {
    SessionStatus session;
    session.established = established_;
    if (monitor_.has_session()) session.session_id = monitor_.session_id();
    return session;
  }

  // Strand only.
  Table table_;
  session::HeartbeatSchedule heartbeat_;
  Monitor monitor_;
  client::MessageIds ids_;
  std::array<UntrackedId, 8> untracked_{};
  std::size_t untracked_next_ = 0;
  std::map<std::uint32_t, Sends::iterator> in_flight_;  // by messageId
  std::set<std::uint32_t> lanes_;                        // pins with a message in flight
  std::size_t replays_outstanding_ = 0;                  // replays queued or in flight in this round
  std::size_t replayed_this_round_ = 0;
  bool monitor_done_ = false;  // the monitor handed out every replay of this round
  bool established_ = false;
  bool ever_established_ = false;
  bool failsafe_seen_ = false;
  std::pair<std::uint32_t, std::uint32_t> detected_{0, 0};  // (stored, reported) of the last reset detected
  std::set<std::uint32_t> initialised_pins_;  // pins whose init the device acked in this session
  bool state_lost_ = false;  // the device refused a message for want of an init it had acked (lost_an_init)
};

}  // namespace

std::shared_ptr<ClientImpl> make_primary_client(std::shared_ptr<transports::ByteStream> stream, const Options& options) {
  return std::make_shared<PrimaryClient>(std::move(stream), options);
}

}  // namespace tether::proxy::detail
