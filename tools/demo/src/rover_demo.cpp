// `tether demo`: runs the servo workload on every device of a rover at once; see rover_demo.hpp.
#include "tether/demo/rover_demo.hpp"
#include "tether/demo/workload.hpp"

#include <boost/asio/use_future.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <type_traits>
#include <variant>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/exactly_once.hpp"
#include "tether/devices/codec_rows.hpp"
#include "tether/devices/rover.hpp"
#include "tether/elcano/node/behaviour.hpp"
#include "tether/proxy/device/pins.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/transports/fault_injecting_stream.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::demo {

namespace {

using Clock = std::chrono::steady_clock;
using error_code = boost::system::error_code;

}  // namespace

devices::Rover open_rover_with_fault_links(const devices::RoverConfig& config,
                                           const boost::asio::any_io_executor& executor, std::uint64_t seed,
                                           std::vector<std::shared_ptr<transports::FaultInjectingStream>>& links) {
  // wrap_stream runs on this thread, once per device in config order (open_rover blocks).
  links.clear();
  devices::OpenOptions open_options;
  std::uint64_t stream_seed = seed;
  open_options.wrap_stream = [&](const devices::DeviceConfig&, std::shared_ptr<transports::ByteStream> stream) {
    links.push_back(transports::FaultInjectingStream::wrap(std::move(stream), {}, {}, stream_seed++));
    return std::shared_ptr<transports::ByteStream>(links.back());
  };
  return devices::open_rover(config, executor, open_options);
}

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

namespace {

// The workloads of every codec: the plugins', then the ones registered at run time.
devices::CodecRows<CodecWorkloads>& workload_table() {
  static devices::CodecRows<CodecWorkloads> instance(detail::plugin_workload_rows());
  return instance;
}

}  // namespace

const CodecWorkloads* codec_workloads(devices::Codec codec) {
  return workload_table().find(devices::to_string(codec));
}

void register_workloads(CodecWorkloads workloads) {
  if (!workloads.make) throw std::invalid_argument("register_workloads: no make function");
  workload_table().add(std::move(workloads), "register_workloads");
}

std::unique_ptr<Workload> make_workload(const devices::RoverDevice& device, const devices::DeviceConfig& config,
                                        WorkloadKind kind, Payload payload, std::string& why) {
  const CodecWorkloads* row = codec_workloads(device.codec);
  if (row == nullptr) {
    why = "no " + std::string(to_string(kind)) + " operation for codec " +
          std::string(devices::to_string(device.codec));
    return nullptr;
  }
  return row->make(device, config, kind, payload, why);
}

std::unique_ptr<Workload> make_workload(const devices::RoverDevice& device, const devices::DeviceConfig& config) {
  std::string why;
  std::unique_ptr<Workload> workload = make_workload(device, config, WorkloadKind::servo, Payload::demo, why);
  if (!workload) {
    throw std::invalid_argument(why.starts_with("no servo operation for codec ")
                                    ? "the demo has no servo workload for codec " +
                                          std::string(devices::to_string(device.codec))
                                    : why);
  }
  return workload;
}

namespace {

// Operation times in bounded memory (a soak runs for hours): buckets 0.5 % wide from 1 us up, so a
// percentile is the nearest-rank sample's bucket bound, within 0.5 % of it; the maximum is exact.
class LatencyHistogram {
 public:
  void add(double ms) {
    max_ = std::max(max_, ms);
    ++count_;
    ++buckets_[bucket(ms)];
  }
  double max() const { return max_; }
  // Nearest rank: the smallest value with at least `fraction` of the samples at or below it.
  double percentile(double fraction) const {
    if (count_ == 0) return 0;
    const auto rank = std::max<std::uint64_t>(
        1, static_cast<std::uint64_t>(std::ceil(fraction * static_cast<double>(count_))));
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < buckets_.size(); ++b) {
      seen += buckets_[b];
      if (seen >= rank) return std::min(kFloorMs * std::pow(kRatio, static_cast<double>(b)), max_);
    }
    return max_;
  }

 private:
  static constexpr double kFloorMs = 0.001;
  static constexpr double kRatio = 1.005;
  static constexpr std::size_t kBuckets = 4200;  // up to ~22 min
  static std::size_t bucket(double ms) {
    if (!(ms > kFloorMs)) return 0;
    const double index = std::ceil(std::log(ms / kFloorMs) / std::log(kRatio));
    return std::min(kBuckets - 1, static_cast<std::size_t>(index));
  }
  std::vector<std::uint64_t> buckets_ = std::vector<std::uint64_t>(kBuckets);
  std::uint64_t count_ = 0;
  double max_ = 0;
};

// The last complete pulse of `pin` (us), or 0 when the pin stopped pulsing: no edge for a servo period and
// more (a rebooted board that never got its init back still shows its last pulse from before the reset).
double pulse_us(transports::VirtualUno& board, int pin) {
  const transports::PulseTiming timing = board.pulse_timing(pin);
  if (board.simulated_time() - timing.last_edge > std::chrono::milliseconds(25)) return 0;
  return std::chrono::duration<double, std::micro>(timing.high_time).count();
}

// Compares the pins with `last` (the command the pins should show), once the servo period has passed (20 ms).
// The wait is in the board's time (500 ms: 25 periods), not the wall clock's, so that how many pulses are
// looked at does not depend on the machine's load (a loaded suite once ended a 2 s wall-clock window on
// "D9 2190/2193 us": cause not pinned down). The wall-clock bound only ends the wait on a stopped board.
void check_pins(DeviceReport& report, transports::VirtualUno& board, const std::optional<Pulses>& last) {
  if (!last) return;
  const auto settled = board.simulated_time() + std::chrono::milliseconds(500);
  const auto stalled = Clock::now() + std::chrono::seconds(30);
  bool match = false;
  double d9 = 0;
  double d10 = 0;
  while (true) {
    d9 = pulse_us(board, 9);
    d10 = pulse_us(board, 10);
    match = (last->d9 == 0 || std::abs(d9 - last->d9) < last->tolerance_us) &&
            (last->d10 == 0 || std::abs(d10 - last->d10) < last->tolerance_us);
    if (match || board.simulated_time() > settled || Clock::now() > stalled) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  report.pins_match = match;
  const auto describe = [](double measured, std::uint16_t expected) {
    return std::to_string(static_cast<int>(std::lround(measured))) + "/" + std::to_string(expected) + " us";
  };
  report.pins_detail = "D9 " + (last->d9 == 0 ? std::string("-") : describe(d9, last->d9)) + ", D10 " +
                       (last->d10 == 0 ? std::string("-") : describe(d10, last->d10));
}

// What a device's run leaves for the count after the rover closed: its workload (the client's counters).
struct DeviceRun {
  std::unique_ptr<Workload> workload;
};

// Runs the workload of one device; fills `report` (its link counts once the rover is closed: run_demo).
void run_device(const DemoOptions& options, const devices::RoverDevice& device, const devices::DeviceConfig& config,
                const std::shared_ptr<transports::FaultInjectingStream>& link, DeviceReport& report, DeviceRun& run) {
  run.workload = make_workload(device, config);
  Workload* const workload = run.workload.get();
  report.operation = workload->operation();
  report.confirmed = workload->confirms();
  transports::FaultConfig noise;
  noise.bit_error_rate = options.bit_error_rate;
  if (link) link->set_faults(noise, noise);
  const std::optional<std::uint32_t> resets_before = workload->resets_detected();

  // The device that executes the commands: a ring's last board drives the servos.
  std::optional<ExecutionWitness> witness;
  if (!device.boards.empty()) witness = ExecutionWitness::attach(*device.boards.back());
  if (witness) witness->read();  // what opening did (nothing the workload sent) is not counted
  ExactlyOnceLedger ledger;

  LatencyHistogram latencies;
  std::optional<Pulses> last_ok;
  // Operations that are one device command: what the pins show is the last one the witness saw EXECUTED,
  // confirmed or not (an arm call whose answer was lost after it ran left the pins at its values,
  // and the check against the last confirmed one reported a mismatch). Newest last; a key repeats only
  // after hundreds of operations.
  std::deque<std::pair<std::uint32_t, Pulses>> single_commands;
  std::optional<Pulses> last_executed;
  const auto note_executions = [&](const ExecutionWitness::Reading& reading) {
    ledger.add(reading);
    if (reading.keys.empty()) return;
    for (auto command = single_commands.rbegin(); command != single_commands.rend(); ++command) {
      if (command->first == reading.keys.back()) {
        last_executed = command->second;
        return;
      }
    }
    last_executed.reset();  // an execution no single command explains: fall back to the last success
  };
  std::optional<Clock::time_point> reset_at;
  const unsigned reset_index = options.iterations / 2;
  const bool timed = options.duration.count() > 0;
  const auto stop_at = Clock::now() + options.duration;
  const auto reset_now = [&](unsigned i) {
    if (options.reset_every > 0) return i > 0 && i % options.reset_every == 0;
    return options.reset_halfway && !timed && i == reset_index;
  };
  auto next_start = Clock::now();
  for (unsigned i = 0; timed ? Clock::now() < stop_at : i < options.iterations; ++i) {
    std::this_thread::sleep_until(next_start);
    next_start = std::max(next_start + options.period, Clock::now());
    if (reset_now(i) && !device.boards.empty()) {
      if (witness) note_executions(witness->read());  // the reboot clears what was not read yet
      device.boards.back()->reset(transports::ResetKind::power_cycle, options.power_off);
      reset_at = Clock::now();
      report.recovery_ms.reset();  // the latest reset's recovery
      ++report.resets_injected;
    }
    const auto start = Clock::now();
    const Outcome outcome = workload->run(i);
    const auto end = Clock::now();
    latencies.add(std::chrono::duration<double, std::milli>(end - start).count());
    ++report.operations;
    for (const auto& [key, confirmed] : outcome.commands) ledger.outcome(ledger.issued(key), confirmed);
    if (outcome.commands.size() == 1) {
      single_commands.emplace_back(outcome.commands.front().first, outcome.expected);
      if (single_commands.size() > ExactlyOnceLedger::kAttributionWindow) single_commands.pop_front();
    }
    if (witness) note_executions(witness->read());
    if (outcome.ok) {
      ++report.successes;
      last_ok = outcome.expected;
      if (reset_at && !report.recovery_ms && workload->confirms()) {
        report.recovery_ms = std::chrono::duration<double, std::milli>(end - *reset_at).count();
      }
    } else {
      if (outcome.wrong) {
        ++report.wrong;
      } else {
        ++report.failures;
      }
      if (report.first_error.empty()) report.first_error = "operation " + std::to_string(i) + ": " + outcome.error;
      const std::string& cause = outcome.cause.empty() ? outcome.error : outcome.cause;
      if (report.failure_causes.size() < kMaxFailureCauses || report.failure_causes.count(cause) != 0) {
        ++report.failure_causes[cause];
      } else {
        ++report.failure_causes["other"];
      }
    }
    if (options.progress) options.progress(device.name, i + 1, timed ? 0 : options.iterations);
  }
  if (link) link->set_faults({}, {});
  if (witness) {
    // Re-sends still in flight land within a call budget (2 s); the compat settle's re-writes are not the
    // workload's and are not counted.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    note_executions(witness->read());
    report.exactly_once = ledger.figures();
  }
  if (last_executed) last_ok = last_executed;
  if (const std::optional<Pulses> settled = workload->settle(report.final_rewrites)) last_ok = settled;

  if (const auto resets = workload->resets_detected()) report.resets_detected = *resets - resets_before.value_or(0);
  if (link) {
    const transports::FaultCounts to = link->to_device_counts();
    const transports::FaultCounts from = link->from_device_counts();
    report.bytes_to_device = to.bytes_in;
    report.bytes_from_device = from.bytes_in;
    report.bits_flipped = to.bits_flipped + from.bits_flipped;
  }
  report.latency_p50_ms = latencies.percentile(0.50);
  report.latency_p99_ms = latencies.percentile(0.99);
  report.latency_max_ms = latencies.max();
  if (!device.boards.empty()) check_pins(report, *device.boards.back(), last_ok);
}

}  // namespace

DemoReport run_demo(const DemoOptions& options) {
  const auto started = Clock::now();
  devices::ParseOptions parse;
  parse.firmware_dir = options.firmware_dir;
  const devices::RoverConfig config =
      options.config ? *options.config : devices::parse_config(devices::default_virtual_rover_config(), parse);

  transports::IoThread io;
  std::vector<std::shared_ptr<transports::FaultInjectingStream>> links;
  devices::Rover rover = open_rover_with_fault_links(config, io.executor(), options.seed, links);

  DemoReport report;
  report.rover = config.name;
  report.iterations = options.iterations;
  report.bit_error_rate = options.bit_error_rate;
  report.reset_halfway = options.reset_halfway;
  report.duration = options.duration;
  report.reset_every = options.reset_every;
  report.devices.resize(rover.devices().size());
  std::vector<std::thread> threads;
  std::mutex error_mutex;
  std::exception_ptr first_exception;
  std::vector<DeviceRun> runs(rover.devices().size());
  for (std::size_t k = 0; k < rover.devices().size(); ++k) {
    const devices::RoverDevice& device = rover.devices()[k];
    DeviceReport& device_report = report.devices[k];
    device_report.device = device.name;
    device_report.codec = std::string(devices::to_string(device.codec));
    device_report.transport = device.transport;
    threads.emplace_back([&, k] {
      try {
        run_device(options, rover.devices()[k], config.devices[k], links[k], report.devices[k], runs[k]);
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!first_exception) first_exception = std::current_exception();
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  rover.close();
  if (first_exception) std::rethrow_exception(first_exception);
  // The links' counters over their whole sessions, taken once the clients are closed: what a capture of
  // the run records (a re-send while a device opened, on a loaded machine; a late answer to a re-send after
  // the workload ended), every frame read being one a client took.
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (!runs[k].workload) continue;
    const LinkCounters link = runs[k].workload->link();
    DeviceReport& device_report = report.devices[k];
    device_report.retries = link.retries;
    device_report.stale = link.stale;
    device_report.crc_errors = link.crc_errors;
    device_report.framing_errors = link.framing_errors;
    device_report.resyncs = link.resyncs;
  }
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - started).count();
  return report;
}

}  // namespace tether::demo
