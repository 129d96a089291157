// The Romi codec's workloads for `tether demo` and `tether bench` (tools/demo/include/tether/demo/workload.hpp):
// the servos `S[t,s]` (large: `L[t,s,"label"]`), the ADC `A[ch]` (large: `R`).
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
#include "tether/romi/plugin.hpp"

namespace tether::demo {

namespace {

using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

class RomiWorkload final : public Workload {
 public:
  explicit RomiWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "call S[throttle_us,steering_us] -> [0]"; }
  Outcome run(unsigned i) override {
    Outcome outcome;
    outcome.expected = {throttle_us(i), steering_us(i)};
    error_code error;
    const romi::RomiResponse response =
        client_->call("S[" + std::to_string(outcome.expected.d9) + "," + std::to_string(outcome.expected.d10) + "]",
                      error);
    if (error) {
      outcome.error = error.message();
    } else if (response.code != 0) {
      outcome.error = "device answered " + response.values.dump();
      outcome.cause = "device answered code " + std::to_string(response.code);
    } else {
      outcome.ok = true;
    }
    outcome.commands.emplace_back(witness_key(outcome.expected.d9, outcome.expected.d10), outcome.ok);
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  std::shared_ptr<romi::Client> client_;
};

class RomiSensorWorkload final : public Workload {
 public:
  explicit RomiSensorWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "call A[channel 0..5] -> [0,value 0..1023]"; }
  Outcome run(unsigned i) override {
    Outcome outcome;
    error_code error;
    const romi::RomiResponse response = client_->call("A[" + std::to_string(i % kChannels) + "]", error);
    if (error) {
      outcome.error = error.message();
    } else if (response.code != 0) {
      outcome.error = "device answered " + response.values.dump();
      outcome.cause = "device answered code " + std::to_string(response.code);
    } else if (response.values.size() != 2 || !response.values[1].is_number_integer() ||
               response.values[1].get<int>() < 0 || response.values[1].get<int>() > kAdcMax) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "reading " + response.values.dump() + " is not [0, 0..1023]";
    } else {
      outcome.ok = true;
    }
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  static constexpr unsigned kChannels = 6;  // A0..A5
  static constexpr int kAdcMax = 1023;      // 10-bit ADC
  std::shared_ptr<romi::Client> client_;
};

// A Romi call whose answer `check` accepts (empty string) or rejects (why: a wrong answer).
template <typename Check>
Outcome romi_call(romi::Client& client, const std::string& request, Check check) {
  Outcome outcome;
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
class RomiLabelledServoWorkload final : public Workload {
 public:
  explicit RomiLabelledServoWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override {
    return "call L[throttle_us,steering_us,\"" + std::to_string(kLabelLength) + "-char label\"] -> [0," +
           std::to_string(kLabelLength) + "]";
  }
  Outcome run(unsigned i) override {
    const std::uint16_t throttle = throttle_us(i);
    const std::uint16_t steering = steering_us(i);
    std::string label = "manoeuvre-" + std::to_string(i) + "-";
    label.resize(kLabelLength, '.');
    Outcome outcome = romi_call(
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
class RomiAllChannelsWorkload final : public Workload {
 public:
  explicit RomiAllChannelsWorkload(std::shared_ptr<romi::Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "call R -> [0,a0,...,a5] (A0..A5, 0..1023 each)"; }
  Outcome run(unsigned) override {
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


std::unique_ptr<Workload> make_romi(const devices::RoverDevice& device, const devices::DeviceConfig&,
                                    WorkloadKind kind, Payload payload, std::string&) {
  const auto client = device.client.get<romi::Client>();
  const bool large = payload == Payload::large;
  if (kind == WorkloadKind::sensor) {
    if (large) return std::make_unique<RomiAllChannelsWorkload>(client);
    return std::make_unique<RomiSensorWorkload>(client);
  }
  if (large) return std::make_unique<RomiLabelledServoWorkload>(client);
  return std::make_unique<RomiWorkload>(client);
}

}  // namespace

}  // namespace tether::demo

namespace tether::romi {

/// The codec's workloads (collected by tools/demo/CMakeLists.txt: plugin_workloads.cpp.in).
std::vector<demo::CodecWorkloads> workload_rows();

std::vector<demo::CodecWorkloads> workload_rows() { return {{"romi", demo::make_romi}}; }

}  // namespace tether::romi
