// The proxy client's compatibility mode: the deployed variant (RocketryProto, no CRC). No ids, acks, pings
// or sessions: a send completes when its frame was written (or fails when the stream did not take it
// within `send_budget`), device messages become events, and the deployed host's staleness rule reports a
// pin that stopped reporting. The shared part (link, pending sends, inits, pins, events) is client_impl.hpp.
#include <boost/asio/error.hpp>

#include <memory>
#include <mutex>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "client_impl.hpp"

namespace tether::proxy::detail {
namespace {

class CompatClient final : public ClientImpl {
 public:
  CompatClient(std::shared_ptr<transports::ByteStream> stream, const Options& options)
      : ClientImpl(std::move(stream), options, Integrity::none) {}

 private:
  Built build(Request& request) const override {
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

  void on_started(Millis now) override { (void)now; }

  // A send completes when its frame was written (or could not be), or with `timed_out` when the stream did
  // not take it within `send_budget` (a device that stopped reading). The frame stays queued then (a write
  // cannot be taken back); its write's completion finds the send gone.
  void on_accepted(Sends::iterator send, Millis now) override {
    ++counters_.messages_sent;
    send->state.stage = Send::Stage::writing;
    send->deadline.arm(now, options_.timing.send_budget);
    const OperationId operation = send->id;
    write(frame_of(serialize(send->state.message), Integrity::none), [this, operation](error_code error) {
      const Sends::iterator written = sends_.find(operation);
      if (written == sends_.end()) return;  // timed out already
      SendResult result;
      if (!error) result.attempts = 1;
      sends_.complete(written, error, result);
    });
    pump(now);  // an init starts its pin's staleness clock
  }

  void restart(Millis now) override {
    (void)now;
    RocketryProto::ArduinoIn reset;
    reset.mutable_reset();
    write(frame_of(reset.SerializeAsString(), Integrity::none));
    ++counters_.resets_sent;
  }

  // A device that lost power with its port sent its RESET event to nobody: replayed as if it had arrived.
  void on_restored(Millis now) override {
    if (options_.compat_replay_on_reset) replay_inits();
    pump(now);
  }

  void on_payload(ByteView payload, Millis now) override {
    RocketryProto::ArduinoOut out;
    if (!out.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
      undecodable(payload, true);
      return;
    }
    switch (out.data_case()) {
      case RocketryProto::ArduinoOut::kEventMessage:
        emit(events::CompatEvent{out.eventmessage().type(), out.eventmessage().data()});
        if (out.eventmessage().type() == RocketryProto::RESET && options_.compat_replay_on_reset) replay_inits();
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

  // The device ended its setup; every registered init again, in registration order.
  void replay_inits() {
    for (const InitKey key : init_order_) {
      write(frame_of(serialize(inits_.at(key).message), Integrity::none));
      ++counters_.inits_replayed;
    }
  }

  void pump(Millis now) override {
    if (!is_open() || link_error()) return;
    sends_.expire(now, [](Sends::Operation&) { return std::tuple<error_code, SendResult>(ProxyError::timed_out, SendResult()); });
    check_stale(now);
    arm_timer();
    publish();
  }

  // Pins silent for `stale_after` are lost (once, until they report again).
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

  void arm_timer() {
    Deadline wakeup = sends_.next_deadline();
    std::lock_guard lock(mutex_);
    for (const auto& [key, entry] : pins_) {
      if (!entry.status.stale) {
        consider(wakeup, deadline_at(static_cast<Millis>(entry.status.updated + options_.timing.stale_after)));
      }
    }
    ClientLink::arm_timer(wakeup);
  }

  // Every send is a write on the stream: aborting the writes completes them (the one being written
  // finishes, and completes as it went).
  void fail_all(const error_code& error) override { abort_writes(error); }

  SessionStatus session_status() const override {
    SessionStatus session;
    session.established = !link_error() && is_open();
    return session;
  }
};

}  // namespace

std::shared_ptr<ClientImpl> make_compat_client(std::shared_ptr<transports::ByteStream> stream, const Options& options) {
  return std::make_shared<CompatClient>(std::move(stream), options);
}

}  // namespace tether::proxy::detail
