// The Elcano codec's workloads for `tether demo` and `tether bench` (tools/demo/include/tether/demo/workload.hpp):
// a drive, a segment or a goal round the ring, answered by the drive node's report.
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
#include "tether/elcano/node/behaviour.hpp"
#include "tether/elcano/plugin.hpp"

namespace tether::demo {

namespace {

using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

class ElcanoWorkload final : public Workload {
 public:
  explicit ElcanoWorkload(std::shared_ptr<elcano::RingClient> client) : client_(std::move(client)) {}
  std::string operation() const override { return "request D{s}{a} -> the drive node's S report"; }
  Outcome run(unsigned i) override {
    Outcome outcome;
    const elcano::Message drive = elcano::Message::drive(static_cast<std::int32_t>((i * 97u) % 1600u) - 800,
                                                         static_cast<std::int32_t>((i * 7u) % 61u) - 30);
    outcome.expected = {elcano::node::throttle_pulse_us(drive.speed), elcano::node::steering_pulse_us(drive.angle)};
    error_code error;
    const elcano::Message reply = client_->request(drive, elcano::Type::sensor, error);
    if (error) {
      outcome.error = error.message();
    } else if (reply.speed != drive.speed || reply.angle != drive.angle) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "report s=" + std::to_string(reply.speed) + " a=" + std::to_string(reply.angle) +
                      " for s=" + std::to_string(drive.speed) + " a=" + std::to_string(drive.angle);
    } else {
      outcome.ok = true;
    }
    // The drive node's key: the drive's speed and angle.
    outcome.commands.emplace_back(
        witness_key(static_cast<std::uint16_t>(drive.speed), static_cast<std::uint16_t>(drive.angle)), outcome.ok);
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }

 private:
  std::shared_ptr<elcano::RingClient> client_;
};

// Elcano: a segment or a goal request round the ring, answered by the drive node's sensor report of the
// drive the segment node derived (tether/elcano/node/behaviour.hpp): s = the segment's s (a goal's
// segment: kCruiseSpeed), a = steering towards the bearing b from heading 0 (the host captures the
// sensor reports, so the segment node never sees one).
class ElcanoRoundWorkload final : public Workload {
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
  Outcome run(unsigned i) override {
    Outcome outcome;
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


std::unique_ptr<Workload> make_elcano(const devices::RoverDevice& device, const devices::DeviceConfig&,
                                      WorkloadKind kind, Payload payload, std::string&) {
  const auto ring = device.client.get<elcano::RingClient>();
  const bool large = payload == Payload::large;
  if (kind == WorkloadKind::sensor) return std::make_unique<ElcanoRoundWorkload>(ring, elcano::Type::goal, large);
  if (large) return std::make_unique<ElcanoRoundWorkload>(ring, elcano::Type::segment, true);
  return std::make_unique<ElcanoWorkload>(ring);
}

}  // namespace

}  // namespace tether::demo

namespace tether::elcano {

/// The codec's workloads (collected by tools/demo/CMakeLists.txt: plugin_workloads.cpp.in).
std::vector<demo::CodecWorkloads> workload_rows();

std::vector<demo::CodecWorkloads> workload_rows() { return {{"elcano", demo::make_elcano}}; }

}  // namespace tether::elcano
