// The proxy codec's workloads for `tether demo` and `tether bench` (tools/demo/include/tether/demo/workload.hpp):
// ServoControls acked (the demo's), one DigitalControl or ServoControl, a pin read back.
#include <boost/asio/use_future.hpp>

#include <chrono>
#include <condition_variable>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/workload.hpp"
#include "tether/proxy/device/pins.hpp"
#include "tether/proxy/plugin.hpp"

namespace tether::demo {

namespace {

using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

class ProxyWorkload final : public Workload {
 public:
  ProxyWorkload(std::shared_ptr<proxy::Client> client, std::vector<proxy::PinInit> servo_inits, bool compat)
      : client_(std::move(client)), inits_(std::move(servo_inits)), compat_(compat) {
    if (inits_.empty()) throw std::invalid_argument("the proxy device has no servo init to drive");
    if (inits_.size() > 2) inits_.resize(2);
    for (const proxy::PinInit& init : inits_) pins_.push_back(init.pin);
  }
  std::string operation() const override {
    std::string text = std::to_string(pins_.size()) + " x ServoControl";
    return text + (compat_ ? " written, unconfirmed (no acks in this variant)" : " -> Ack each");
  }
  Outcome run(unsigned i) override {
    Outcome outcome;
    std::vector<std::future<proxy::SendResult>> sends;
    last_positions_.clear();
    for (std::size_t k = 0; k < pins_.size(); ++k) {
      const std::int32_t position = degrees(i, k == 0 ? 37u : 53u);
      last_positions_.push_back(position);
      set_expected(outcome.expected, pins_[k], pulse_us(position));
      sends.push_back(client_->servo(pins_[k]).async_set(position, boost::asio::use_future));
    }
    outcome.ok = true;
    for (std::size_t k = 0; k < sends.size(); ++k) {
      bool sent = true;
      try {
        sends[k].get();
      } catch (const boost::system::system_error& error) {  // what use_future throws for an error_code
        if (outcome.ok) outcome.error = error.code().message();
        outcome.ok = false;
        sent = false;
      }
      // The firmware's key: pin, position.
      outcome.commands.emplace_back(
          witness_key(static_cast<std::uint16_t>(pins_[k]), static_cast<std::uint16_t>(last_positions_[k])), sent);
    }
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }
  bool confirms() const override { return !compat_; }
  std::optional<std::uint32_t> resets_detected() const override {
    if (compat_) return std::nullopt;  // compat announces RESET, but has no session to tell restarts apart
    return client_->counters().link.resets;
  }
  // Compat: nothing is acked, so a write lost in the reboot (or to noise) leaves a pin at an older value,
  // and a RESET announcement lost to noise leaves the rebooted device without its inits (the client
  // replays them on that announcement). Write each servo's init and last position again until the
  // device's state stream (~50 ms) reports the position -- the only witness this variant has; the device
  // ignores an init of a pin it already has. The deployed host does none of this; the demo does it so the
  // pin check compares with a known command.
  std::optional<Pulses> settle(std::uint32_t& rewrites) override {
    if (!compat_ || last_positions_.empty()) return std::nullopt;
    Pulses expected;
    // Degrees on the deployed Servo library's 544..2400 us: 10.3 us a degree. Its timer-interrupt pulses are
    // exact but for an edge whose compare meets the UART's interrupt routine: held off up to ~80 cycles
    // measured, that pulse is up to ~5.3 us short (ProxyCompatPins.AServoPulseIsItsTicksGiveOrTakeTheInterrupt
    // ThatDelayedAnEdge, edge cycles against compares in simavr). The pin check saw one such pulse, 2190 us for
    // 2193, which a 2 us tolerance counted as another command; the check passes on any matching pulse of 500 ms
    // of them, and such a pulse is rare (8 of 99 with a control every millisecond, none at one a frame).
    expected.tolerance_us = 5.0;
    for (std::size_t k = 0; k < pins_.size(); ++k) set_expected(expected, pins_[k], pulse_us(last_positions_[k]));
    const auto give_up = Clock::now() + std::chrono::seconds(5);
    while (Clock::now() < give_up) {
      const auto written = Clock::now();
      const Millis written_ms = client_->now();  // the clock of the pins' `updated`
      for (std::size_t k = 0; k < pins_.size(); ++k) {
        error_code error;
        client_->servo(pins_[k]).init(inits_[k].safe_value, error);
        client_->servo(pins_[k]).set(last_positions_[k], error);
        ++rewrites;
      }
      const auto wait_until = std::min(give_up, written + std::chrono::milliseconds(300));
      while (Clock::now() < wait_until) {
        if (reported_since(written_ms)) return expected;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    return expected;  // never reported: the pin check shows what the pins do
  }

 private:
  bool reported_since(Millis written) const {
    for (std::size_t k = 0; k < pins_.size(); ++k) {
      const std::optional<proxy::PinStatus> state = client_->servo(pins_[k]).state();
      if (!state || !state->has_value || tick_difference(state->updated, written) <= 0 ||
          state->value != last_positions_[k]) {
        return false;
      }
    }
    return true;
  }
  // The pulse a position gives: the primary image's 1000..2000 us, or the deployed Servo library's
  // 544..2400 us that proxy-compat reproduces.
  std::uint16_t pulse_us(std::int32_t position) const {
    return compat_ ? proxy::device::arduino_servo_pulse_us(static_cast<std::int16_t>(position))
                   : proxy::device::servo_pulse_us(position);
  }
  static void set_expected(Pulses& pulses, std::uint32_t pin, std::uint16_t us) {
    if (pin == 9) pulses.d9 = us;
    if (pin == 10) pulses.d10 = us;
  }
  std::shared_ptr<proxy::Client> client_;
  std::vector<proxy::PinInit> inits_;  // the servo inits of the config (at most two)
  std::vector<std::uint32_t> pins_;      // their pins
  bool compat_;
  std::vector<std::int32_t> last_positions_;  // of the last operation, one per pin
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
class ProxyControlWorkload final : public Workload {
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
  Outcome run(unsigned i) override {
    Outcome outcome;
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
  bool reported_after(std::uint64_t before, std::int32_t value, Outcome& outcome) const {
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

// The first init of `kind` in a proxy device's config: the pin a one-pin operation drives.
std::optional<std::uint32_t> first_pin(const devices::DeviceConfig& config, proxy::PinInit::Kind kind) {
  for (const proxy::PinInit& init : config.options.get<proxy::DeviceOptions>().inits) {
    if (init.kind == kind) return init.pin;
  }
  return std::nullopt;
}


std::unique_ptr<Workload> make_proxy(const devices::RoverDevice& device, const devices::DeviceConfig& config,
                                     WorkloadKind kind, Payload payload, std::string& why) {
  const auto client = device.client.get<proxy::Client>();
  if (kind == WorkloadKind::servo && payload == Payload::demo) {
    std::vector<proxy::PinInit> servos;
    for (const proxy::PinInit& init : config.options.get<proxy::DeviceOptions>().inits) {
      if (init.kind == proxy::PinInit::Kind::servo) servos.push_back(init);
    }
    return std::make_unique<ProxyWorkload>(client, std::move(servos), client->mode() == proxy::Mode::compat);
  }
  const bool servo = payload == Payload::large;
  const auto pin = first_pin(config, servo ? proxy::PinInit::Kind::servo : proxy::PinInit::Kind::digital);
  if (!pin) {
    why = std::string("its config inits no ") + (servo ? "servo" : "digital") + " pin for the " + to_string(payload) +
          " operation";
    return nullptr;
  }
  return std::make_unique<ProxyControlWorkload>(client, *pin, servo, kind == WorkloadKind::sensor);
}

}  // namespace

}  // namespace tether::demo

namespace tether::proxy {

/// The codec's workloads (collected by tools/demo/CMakeLists.txt: plugin_workloads.cpp.in).
std::vector<demo::CodecWorkloads> workload_rows();

std::vector<demo::CodecWorkloads> workload_rows() { return {{"proxy", demo::make_proxy}, {"proxy-compat", demo::make_proxy}}; }

}  // namespace tether::proxy
