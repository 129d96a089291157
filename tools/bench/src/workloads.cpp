// The operations `tether bench` measures per codec, workload and payload; see workloads.hpp.
#include "tether/bench/workloads.hpp"

#include <boost/asio/use_future.hpp>

#include <chrono>
#include <condition_variable>
#include <future>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "tether/core/execution_witness.hpp"
#include "tether/elcano/node/behaviour.hpp"
#include "tether/proxy/plugin.hpp"

namespace tether::bench {

namespace {

using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

// Values of operation i: spread over their range, different from one operation to the next.
std::uint16_t pulse_us(unsigned i, unsigned stride) { return static_cast<std::uint16_t>(1100 + (i * stride) % 800u); }

// A Romi call whose answer `check` accepts (empty string) or rejects (why: a wrong answer).
template <typename Check>
demo::Outcome romi_call(romi::Client& client, const std::string& request, Check check) {
  demo::Outcome outcome;
  error_code error;
  const romi::RomiResponse response = client.call(request, error);
  if (error) {
    outcome.error = error.message();
  } else if (response.code != 0) {
    outcome.error = "device answered " + response.values.dump();
    outcome.cause = "device answered code " + std::to_string(response.code);
  } else if (const std::string wrong = check(response.values); !wrong.empty()) {
    outcome.wrong = true;
    outcome.cause = "wrong answer";
    outcome.error = wrong;
  } else {
    outcome.ok = true;
  }
  return outcome;
}

bool is_adc_reading(const romi::Value& value) {
  return value.is_number_integer() && value.get<int>() >= 0 && value.get<int>() <= 1023;
}

// Romi servo, large: `L[t,s,"label"]` -> `[0,label length]`, a 55-byte request frame.
class RomiLabelledServoWorkload final : public demo::Workload {
 public:
  explicit RomiLabelledServoWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override {
    return "call L[throttle_us,steering_us,\"" + std::to_string(kLabelLength) + "-char label\"] -> [0," +
           std::to_string(kLabelLength) + "]";
  }
  demo::Outcome run(unsigned i) override {
    const std::uint16_t throttle = pulse_us(i, 73);
    const std::uint16_t steering = pulse_us(i, 131);
    std::string label = "manoeuvre-" + std::to_string(i) + "-";
    label.resize(kLabelLength, '.');
    demo::Outcome outcome = romi_call(
        *client_, "L[" + std::to_string(throttle) + "," + std::to_string(steering) + ",\"" + label + "\"]",
        [](const romi::Values& values) -> std::string {
          if (values.size() == 2 && values[1].is_number_integer() && values[1].get<int>() == kLabelLength) return "";
          return "answer " + values.dump() + " is not [0," + std::to_string(kLabelLength) + "]";
        });
    outcome.expected = {throttle, steering};
    outcome.commands.emplace_back(witness_key(throttle, steering), outcome.ok);
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  static constexpr int kLabelLength = 32;  // the protocol's longest string
  std::shared_ptr<romi::Client> client_;
};

// Romi sensor, large: `R` -> `[0,a0,...,a5]`.
class RomiAllChannelsWorkload final : public demo::Workload {
 public:
  explicit RomiAllChannelsWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "call R -> [0,a0,...,a5] (A0..A5, 0..1023 each)"; }
  demo::Outcome run(unsigned) override {
    return romi_call(*client_, "R", [](const romi::Values& values) -> std::string {
      bool readings = values.size() == 7;
      for (std::size_t k = 1; readings && k < values.size(); ++k) readings = is_adc_reading(values[k]);
      return readings ? "" : "reading " + values.dump() + " is not [0, six values 0..1023]";
    });
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  std::shared_ptr<romi::Client> client_;
};

// The pins' reports (proxy::events::PinReport) as they arrive: the last value and a count per pin.
class PinReports {
 public:
  struct Last {
    std::uint64_t count = 0;  // reports of the pin so far
    std::int32_t value = 0;   // the last one's value
  };
  void add(std::uint32_t pin, std::int32_t value) {
    {
      std::lock_guard lock(mutex_);
      Last& last = pins_[pin];
      ++last.count;
      last.value = value;
    }
    changed_.notify_all();
  }
  Last last(std::uint32_t pin) const {
    std::lock_guard lock(mutex_);
    const auto found = pins_.find(pin);
    return found == pins_.end() ? Last{} : found->second;
  }
  // Waits until a report of `pin` after `before` has `value` or `until` passes; the last report then.
  Last wait_for(std::uint32_t pin, std::uint64_t before, std::int32_t value, Clock::time_point until) const {
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, until, [&] {
      const auto found = pins_.find(pin);
      return found != pins_.end() && found->second.count > before && found->second.value == value;
    });
    const auto found = pins_.find(pin);
    return found == pins_.end() ? Last{} : found->second;
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::map<std::uint32_t, Last> pins_;
};

// Proxy: one control message per operation (a DigitalControl toggling its pin, or a ServoControl with a
// two-byte position), confirmed by its Ack (compat: written); with `read_back`, the operation ends when
// the device's report of the pin shows the commanded value (primary: PinState, sent before the Ack;
// compat: the ~50 ms state stream).
class ProxyControlWorkload final : public demo::Workload {
 public:
  ProxyControlWorkload(std::shared_ptr<proxy::Client> client, std::uint32_t pin, bool servo, bool read_back)
      : client_(std::move(client)), pin_(pin), servo_(servo), read_back_(read_back), compat_(client_->mode() == proxy::Mode::compat) {
    if (read_back_) {
      client_->on_event([reports = reports_](const proxy::Event& event) {
        if (const auto* report = std::get_if<proxy::events::PinReport>(&event)) reports->add(report->pin, report->value);
      });
    }
  }
  std::string operation() const override {
    std::string text = servo_ ? "ServoControl{pin " + std::to_string(pin_) + ", position 128..180}"
                              : "DigitalControl{pin " + std::to_string(pin_) + ", toggled}";
    if (read_back_) return text + (compat_ ? " -> its state-stream report" : " -> PinState (then Ack)");
    return text + (compat_ ? " written, unconfirmed" : " -> Ack");
  }
  demo::Outcome run(unsigned i) override {
    demo::Outcome outcome;
    // Servo positions 128..180: a two-byte varint, the largest a control carries (0..180).
    const std::int32_t value = servo_ ? static_cast<std::int32_t>(128 + (i * 37u) % 53u) : static_cast<std::int32_t>(i % 2);
    const std::uint64_t before = reports_->last(pin_).count;
    const Millis written = client_->now();  // the clock of PinStatus::updated
    try {
      if (servo_) {
        client_->servo(pin_).async_set(value, boost::asio::use_future).get();
      } else {
        client_->digital(pin_).async_set(value != 0, boost::asio::use_future).get();
      }
      outcome.ok = true;
    } catch (const boost::system::system_error& error) {  // what use_future throws for an error_code
      outcome.error = error.code().message();
    }
    // The firmware witnesses servo controls only (key: pin, position).
    if (servo_) outcome.commands.emplace_back(witness_key(static_cast<std::uint16_t>(pin_), static_cast<std::uint16_t>(value)), outcome.ok);
    if (!outcome.ok || !read_back_) return outcome;
    if (compat_ ? reported_since(written, value) : reported_after(before, value, outcome)) return outcome;
    if (!outcome.wrong) {
      outcome.cause = "no read-back";
      outcome.error = "pin " + std::to_string(pin_) + " did not report " + std::to_string(value);
    }
    outcome.ok = false;
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }
  bool confirms() const override { return !compat_ || read_back_; }
  std::optional<std::uint32_t> resets_detected() const override {
    if (compat_) return std::nullopt;
    return client_->counters().link.resets;
  }

 private:
  // Primary: the PinState came before the Ack, so it is here unless noise dropped it (then nothing tells
  // the pin's value). A report with another value is a wrong answer.
  bool reported_after(std::uint64_t before, std::int32_t value, demo::Outcome& outcome) const {
    const PinReports::Last last =
        reports_->wait_for(pin_, before, value, Clock::now() + std::chrono::milliseconds(500));
    if (last.count > before && last.value == value) return true;
    if (last.count > before) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "pin " + std::to_string(pin_) + " reported " + std::to_string(last.value) + " for " +
                      std::to_string(value);
    }
    return false;
  }
  // Compat: the state stream repeats every pin every ~50 ms (events only on changes): waits for a report
  // after the write with the value. An older value meanwhile is no wrong answer (a write lost to noise).
  bool reported_since(Millis written, std::int32_t value) const {
    const auto until = Clock::now() + std::chrono::milliseconds(500);
    const proxy::PinKind kind = servo_ ? proxy::PinKind::servo : proxy::PinKind::digital;
    for (;;) {
      const std::optional<proxy::PinStatus> state = client_->pin_state(kind, pin_);
      if (state && state->has_value && tick_difference(state->updated, written) > 0 && state->value == value) return true;
      if (Clock::now() >= until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  std::shared_ptr<proxy::Client> client_;
  std::uint32_t pin_;
  bool servo_;
  bool read_back_;
  bool compat_;
  std::shared_ptr<PinReports> reports_ = std::make_shared<PinReports>();
};

// Elcano: a segment or a goal request round the ring, answered by the drive node's sensor report of the
// drive the segment node derived (tether/elcano/node/behaviour.hpp): s = the segment's s (a goal's
// segment: kCruiseSpeed), a = steering towards the bearing b from heading 0 (the host captures the
// sensor reports, so the segment node never sees one).
class ElcanoRoundWorkload final : public demo::Workload {
 public:
  ElcanoRoundWorkload(std::shared_ptr<elcano::RingClient> client, elcano::Type type, bool wide)
      : client_(std::move(client)), type_(type), wide_(wide) {}
  std::string operation() const override {
    const std::string values = wide_ ? ", 7-digit positions" : "";
    if (type_ == elcano::Type::segment) {
      return "request X{n}{s}{b}{p" + values + "} -> the segment node's D -> the drive node's S report";
    }
    return "request G{n}{b}{p}" + std::string(wide_ ? "{r}" : "") + values +
           " round the ring (goal -> segment -> drive nodes) -> the drive node's S report";
  }
  demo::Outcome run(unsigned i) override {
    demo::Outcome outcome;
    const auto number = static_cast<std::int32_t>(wide_ ? 100000 + i % 900000 : 1 + i % 9);
    const std::int32_t bearing = static_cast<std::int32_t>((i * 29u) % 360u) - 180;
    const std::int32_t east =
        wide_ ? -1000000 - static_cast<std::int32_t>((i * 7919u) % 8000000u) : static_cast<std::int32_t>(i % 10);
    const std::int32_t north = wide_ ? 1000000 + static_cast<std::int32_t>((i * 104729u) % 8000000u) : 0;
    const elcano::Message request =
        type_ == elcano::Type::segment
            ? elcano::Message::segment(number, static_cast<std::int32_t>((i * 97u) % 1600u) - 800, bearing, east, north)
            : elcano::Message::goal(number, bearing, east, north,
                                    wide_ ? static_cast<std::int32_t>(i % 100) : elcano::kUnset);
    const std::int32_t speed = type_ == elcano::Type::segment ? request.speed : elcano::node::kCruiseSpeed;
    const std::int32_t angle = elcano::node::steering_for(request.bearing, 0);
    outcome.expected = {elcano::node::throttle_pulse_us(speed), elcano::node::steering_pulse_us(angle)};
    error_code error;
    const elcano::Message reply = client_->request(request, elcano::Type::sensor, error);
    if (error) {
      outcome.error = error.message();
    } else if (reply.speed != speed || reply.angle != angle) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "report s=" + std::to_string(reply.speed) + " a=" + std::to_string(reply.angle) +
                      " for s=" + std::to_string(speed) + " a=" + std::to_string(angle);
    } else {
      outcome.ok = true;
    }
    // The drive node's key: the drive's speed and angle.
    outcome.commands.emplace_back(witness_key(static_cast<std::uint16_t>(speed), static_cast<std::uint16_t>(angle)), outcome.ok);
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  std::shared_ptr<elcano::RingClient> client_;
  elcano::Type type_;
  bool wide_;
};

// The first init of `kind` in a proxy device's config: the pin a one-pin operation drives.
std::optional<std::uint32_t> first_pin(const devices::DeviceConfig& config, proxy::PinInit::Kind kind) {
  for (const proxy::PinInit& init : config.options.get<proxy::DeviceOptions>().inits) {
    if (init.kind == kind) return init.pin;
  }
  return std::nullopt;
}

}  // namespace

const char* to_string(WorkloadKind kind) { return kind == WorkloadKind::sensor ? "sensor" : "servo"; }

const char* to_string(Payload payload) {
  switch (payload) {
    case Payload::small:
      return "small";
    case Payload::large:
      return "large";
    case Payload::demo:
      break;
  }
  return "demo";
}

std::unique_ptr<demo::Workload> make_bench_workload(const devices::RoverDevice& device,
                                                    const devices::DeviceConfig& config, WorkloadKind kind,
                                                    Payload payload, std::string& why) {
  const bool large = payload == Payload::large;
  if (const auto romi = device.client.get<romi::Client>()) {
    if (kind == WorkloadKind::sensor) {
      if (large) return std::make_unique<RomiAllChannelsWorkload>(romi);
      return demo::make_sensor_workload(device, why);
    }
    if (large) return std::make_unique<RomiLabelledServoWorkload>(romi);
    return demo::make_workload(device, config);
  }
  if (const auto proxy = device.client.get<proxy::Client>()) {
    if (kind == WorkloadKind::servo && payload == Payload::demo) return demo::make_workload(device, config);
    const bool servo = large;
    const auto pin = first_pin(config, servo ? proxy::PinInit::Kind::servo : proxy::PinInit::Kind::digital);
    if (!pin) {
      why = std::string("its config inits no ") + (servo ? "servo" : "digital") + " pin for the " + to_string(payload) +
            " operation";
      return nullptr;
    }
    return std::make_unique<ProxyControlWorkload>(proxy, *pin, servo, kind == WorkloadKind::sensor);
  }
  if (const auto ring = device.client.get<elcano::RingClient>()) {
    if (kind == WorkloadKind::sensor) return std::make_unique<ElcanoRoundWorkload>(ring, elcano::Type::goal, large);
    if (large) return std::make_unique<ElcanoRoundWorkload>(ring, elcano::Type::segment, true);
    return demo::make_workload(device, config);
  }
  why = "no " + std::string(to_string(kind)) + " operation for codec " + std::string(devices::to_string(device.codec));
  return nullptr;
}

}  // namespace tether::bench
