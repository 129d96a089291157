// `tether bench`: the demo's workload swept over noise and rates on every device; see bench.hpp.
#include "tether/bench/bench.hpp"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "tether/demo/workload.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/fault_injecting_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::bench {

namespace {

using Clock = std::chrono::steady_clock;

double milliseconds(Clock::duration duration) { return std::chrono::duration<double, std::milli>(duration).count(); }

// Nearest rank: the smallest value with at least `fraction` of the samples at or below it (the run keeps
// every sample: a point has at most --iterations of them, or what --duration allows).
double percentile(std::vector<double> samples, double fraction) {
  if (samples.empty()) return 0;
  std::sort(samples.begin(), samples.end());
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(samples.size())));
  return samples[std::min(samples.size(), std::max<std::size_t>(rank, 1)) - 1];
}

// At most `limit` points of the empirical CDF of `samples`: (value, share at or below), evenly spaced in
// rank, always ending with the maximum at 1.
std::vector<std::pair<double, double>> empirical_cdf(std::vector<double> samples, std::size_t limit) {
  std::vector<std::pair<double, double>> cdf;
  if (samples.empty()) return cdf;
  std::sort(samples.begin(), samples.end());
  const std::size_t n = samples.size();
  const std::size_t count = std::min(n, limit);
  for (std::size_t k = 1; k <= count; ++k) {
    const std::size_t rank = (k * n + count - 1) / count;  // 1..n, ceil(k n / count)
    cdf.emplace_back(samples[rank - 1], static_cast<double>(rank) / static_cast<double>(n));
  }
  return cdf;
}

// The workload of one device across the points, with what its figures are measured on.
struct MeasuredDevice {
  const devices::RoverDevice* device = nullptr;
  std::shared_ptr<transports::FaultInjectingStream> link;
  std::unique_ptr<demo::Workload> workload;
  unsigned next_index = 0;  // operation values keep changing across points
  std::optional<double> idle_share;  // awake share of the boards' time with no operation running
  std::optional<demo::ExecutionWitness> witness;  // the executing board's (a ring's last), when its image has one
  std::optional<double> serial_byte_seconds;  // a serial port's configured byte time (8N1: 10 bits per byte)
};

std::uint64_t awake_cycles(const devices::RoverDevice& device) {
  std::uint64_t total = 0;
  for (const auto& board : device.boards) total += board->stats().awake_cycles;
  return total;
}

std::uint64_t all_cycles(const devices::RoverDevice& device) {
  std::uint64_t total = 0;
  for (const auto& board : device.boards) total += board->cycles();
  return total;
}

// Runs one device at one point.
// `witness`: read the execution witness (a ramp step, which reports no exactly-once figures, saves its wait).
PointResult run_point(const BenchOptions& options, MeasuredDevice& measured, double ber, std::optional<double> rate,
                      bool witness = true) {
  const devices::RoverDevice& device = *measured.device;
  demo::Workload& workload = *measured.workload;
  PointResult result;
  result.device = device.name;
  result.workload = options.workload;
  result.payload = options.payload;
  result.bit_error_rate = ber;
  result.rate_hz = rate;

  transports::FaultConfig noise;
  noise.bit_error_rate = ber;
  transports::FaultCounts to_before;
  transports::FaultCounts from_before;
  if (measured.link) {
    to_before = measured.link->to_device_counts();
    from_before = measured.link->from_device_counts();
    measured.link->set_faults(noise, noise);
  }
  const LinkCounters before = workload.link();
  const std::optional<std::uint32_t> resets_before = workload.resets_detected();
  const std::uint64_t awake_before = awake_cycles(device);
  const std::uint64_t cycles_before = all_cycles(device);

  const auto period = rate ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / *rate))
                           : Clock::duration::zero();
  std::vector<double> latencies;
  std::optional<Clock::time_point> reset_at;
  demo::ExactlyOnceLedger ledger;
  if (measured.witness) measured.witness->read();  // executions before the point are not its commands
  const auto started = Clock::now();
  const auto ends = options.duration ? std::optional(started + *options.duration) : std::nullopt;
  const unsigned reset_index = options.iterations / 2;
  auto next_start = started;
  for (unsigned i = 0;; ++i) {
    if (ends ? Clock::now() >= *ends : i >= options.iterations) break;
    std::this_thread::sleep_until(next_start);
    next_start = std::max(next_start + period, Clock::now());
    const bool reset_now = ends ? (!reset_at && Clock::now() >= started + *options.duration / 2) : i == reset_index;
    if (options.reset && reset_now && !device.boards.empty() && !reset_at) {
      if (measured.witness) ledger.add(measured.witness->read());  // the reboot clears what was not read yet
      device.boards.back()->reset(transports::ResetKind::power_cycle, options.power_off);
      reset_at = Clock::now();
      ++result.resets_injected;
    }
    const auto start = Clock::now();
    const demo::Outcome outcome = workload.run(measured.next_index++);
    const auto end = Clock::now();
    latencies.push_back(milliseconds(end - start));
    ++result.operations;
    for (const auto& [key, confirmed] : outcome.commands) ledger.outcome(ledger.issued(key), confirmed);
    if (measured.witness) ledger.add(measured.witness->read());
    if (outcome.ok) {
      ++result.successes;
      if (reset_at && !result.recovery_ms && workload.confirms()) result.recovery_ms = milliseconds(end - *reset_at);
    } else {
      ++(outcome.wrong ? result.wrong : result.failures);
      if (result.first_error.empty()) result.first_error = "operation " + std::to_string(i) + ": " + outcome.error;
    }
  }
  result.seconds = std::chrono::duration<double>(Clock::now() - started).count();
  if (measured.link) measured.link->set_faults({}, {});
  if (measured.witness && witness) {
    // Re-sends still in flight land within a call budget; as the demo, wait a little before the last read.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ledger.add(measured.witness->read());
    result.exactly_once = ledger.figures();
  }

  const LinkCounters after = workload.link();
  result.retries = after.retries - before.retries;
  result.timeouts = after.timeouts - before.timeouts;
  result.stale = after.stale - before.stale;
  result.crc_errors = after.crc_errors - before.crc_errors;
  result.framing_errors = after.framing_errors - before.framing_errors;
  result.oversize = after.oversize_frames - before.oversize_frames;
  if (const auto resets = workload.resets_detected()) result.resets_detected = *resets - resets_before.value_or(0);
  if (measured.link) {
    const transports::FaultCounts to = measured.link->to_device_counts();
    const transports::FaultCounts from = measured.link->from_device_counts();
    result.bytes_to_device = to.bytes_in - to_before.bytes_in;
    result.bytes_from_device = from.bytes_in - from_before.bytes_in;
    result.bits_flipped = (to.bits_flipped - to_before.bits_flipped) + (from.bits_flipped - from_before.bits_flipped);
  }
  if (measured.serial_byte_seconds && result.seconds > 0) {
    result.utilisation_to_device = static_cast<double>(result.bytes_to_device) * *measured.serial_byte_seconds / result.seconds;
    result.utilisation_from_device =
        static_cast<double>(result.bytes_from_device) * *measured.serial_byte_seconds / result.seconds;
  }
  if (!device.boards.empty()) {
    const std::uint64_t awake = awake_cycles(device) - awake_before;
    const std::uint64_t cycles = all_cycles(device) - cycles_before;
    if (result.operations > 0) {
      result.cpu_cycles_per_op = static_cast<double>(awake) / result.operations;
      if (measured.idle_share) {
        result.cpu_cycles_per_op_above_idle =
            (static_cast<double>(awake) - *measured.idle_share * static_cast<double>(cycles)) / result.operations;
      }
    }
    if (cycles > 0) result.cpu_share = static_cast<double>(awake) / static_cast<double>(cycles);
    // The host writes to the first board and reads from the last (a ring); a byte takes its UART's byte time.
    const transports::VirtualUno& first = *device.boards.front();
    const transports::VirtualUno& last = *device.boards.back();
    const auto byte_seconds = [](const transports::VirtualUno& board) {
      const transports::UartStatus uart = board.uart();
      return static_cast<double>(uart.cycles_per_byte) / board.frequency_hz();
    };
    if (result.seconds > 0) {
      result.utilisation_to_device = static_cast<double>(result.bytes_to_device) * byte_seconds(first) / result.seconds;
      result.utilisation_from_device = static_cast<double>(result.bytes_from_device) * byte_seconds(last) / result.seconds;
    }
  }
  result.latency_p50_ms = percentile(latencies, 0.50);
  result.latency_p90_ms = percentile(latencies, 0.90);
  result.latency_p99_ms = percentile(latencies, 0.99);
  result.latency_max_ms = latencies.empty() ? 0 : *std::max_element(latencies.begin(), latencies.end());
  result.latency_cdf = empirical_cdf(std::move(latencies), 50);
  return result;
}

// Highest rate held with >= 99 % success and the lowest swept one that was not, per bit error rate.
void summarise_saturation(BenchReport& report) {
  for (DeviceSummary& device : report.devices) {
    for (const double ber : report.bit_error_rates) {
      DeviceSummary::Saturation saturation;
      saturation.bit_error_rate = ber;
      bool measured = false;
      for (const PointResult& point : report.points) {
        if (point.device != device.device || point.bit_error_rate != ber || point.operations == 0) continue;
        measured = true;
        const double rate = point.rate_hz ? std::min(*point.rate_hz, point.throughput_hz()) : point.throughput_hz();
        if (point.success_share() >= kSustainedSuccess) {
          saturation.sustained_hz = std::max(saturation.sustained_hz.value_or(0), rate);
        } else {
          const double asked = point.rate_hz.value_or(rate);
          saturation.breaks_down_hz = std::min(saturation.breaks_down_hz.value_or(asked), asked);
        }
      }
      if (measured) device.saturation.push_back(saturation);
    }
  }
}

// The saturation ramp of one device at one bit error rate (BenchOptions::saturation_ramp): doubling
// open-loop rates until one is not sustained; the result replaces the sweep's saturation figures.
void ramp_saturation(const BenchOptions& options, MeasuredDevice& measured, double ber, DeviceSummary& summary) {
  DeviceSummary::Saturation saturation;
  saturation.bit_error_rate = ber;
  double rate = options.ramp_start_hz;
  for (unsigned step = 0; step < options.ramp_steps; ++step, rate *= 2) {
    const PointResult point = run_point(options, measured, ber, rate, /*witness=*/false);
    DeviceSummary::Saturation::RampStep ramp_step;
    ramp_step.rate_hz = rate;
    ramp_step.achieved_hz = point.throughput_hz();
    ramp_step.operations = point.operations;
    ramp_step.successes = point.successes;
    ramp_step.latency_p99_ms = point.latency_p99_ms;
    const bool succeeds = point.operations > 0 && point.success_share() >= kSustainedSuccess;
    const bool keeps_up = ramp_step.achieved_hz >= kSustainedThroughput * rate;
    ramp_step.sustained = succeeds && keeps_up;
    saturation.ramp.push_back(ramp_step);
    if (ramp_step.sustained) {
      saturation.sustained_hz = rate;
      continue;
    }
    saturation.breaks_down_hz = rate;
    saturation.breaks_down_because = succeeds ? "throughput" : "success";
    break;
  }
  const auto same_ber = std::find_if(summary.saturation.begin(), summary.saturation.end(),
                                     [&](const DeviceSummary::Saturation& s) { return s.bit_error_rate == ber; });
  if (same_ber == summary.saturation.end()) {
    summary.saturation.push_back(std::move(saturation));
  } else {
    *same_ber = std::move(saturation);
  }
}

std::string hex(const unsigned char* bytes, unsigned size) {
  std::string text;
  char pair[3];
  for (unsigned k = 0; k < size; ++k) {
    std::snprintf(pair, sizeof pair, "%02x", bytes[k]);
    text += pair;
  }
  return text;
}

}  // namespace

double PointResult::success_share() const {
  return operations == 0 ? 0.0 : static_cast<double>(successes) / operations;
}

double PointResult::throughput_hz() const { return seconds > 0 ? operations / seconds : 0.0; }

std::optional<FirmwareImage> describe_firmware(const std::filesystem::path& elf, std::string& error) {
  FirmwareImage image;
  image.path = elf.string();
  std::ifstream file(elf, std::ios::binary);
  if (!file) {
    error = elf.string() + ": cannot read";
    return std::nullopt;
  }
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned digest_size = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &digest_size, EVP_sha256(), nullptr) != 1) {
    error = elf.string() + ": SHA-256 failed";
    return std::nullopt;
  }
  image.sha256 = hex(digest, digest_size);

  // Section sizes as avr-size counts them: flash = .text + .data, RAM = .data + .bss + .noinit (.noinit holds
  // what survives a warm reset, e.g. the proxy's session-id entropy: static RAM all the same).
  if (elf_version(EV_CURRENT) == EV_NONE) {
    error = "libelf: " + std::string(elf_errmsg(-1));
    return std::nullopt;
  }
  Elf* handle = elf_memory(const_cast<char*>(bytes.data()), bytes.size());
  std::size_t names = 0;
  if (handle == nullptr || elf_kind(handle) != ELF_K_ELF || elf_getshdrstrndx(handle, &names) != 0) {
    if (handle != nullptr) elf_end(handle);
    error = elf.string() + ": not an ELF image";
    return std::nullopt;
  }
  for (Elf_Scn* section = elf_nextscn(handle, nullptr); section != nullptr; section = elf_nextscn(handle, section)) {
    GElf_Shdr header;
    if (gelf_getshdr(section, &header) == nullptr) continue;
    const char* name = elf_strptr(handle, names, header.sh_name);
    if (name == nullptr) continue;
    const std::string_view section_name(name);
    if (section_name == ".text" || section_name == ".data") image.flash_bytes += header.sh_size;
    if (section_name == ".data" || section_name == ".bss" || section_name == ".noinit") image.ram_bytes += header.sh_size;
  }
  elf_end(handle);
  return image;
}

BenchReport run_bench(const BenchOptions& options) {
  if (options.bit_error_rates.empty() || options.rates.empty()) throw std::invalid_argument("empty sweep");
  const auto started = Clock::now();
  devices::ParseOptions parse;
  parse.firmware_dir = options.firmware_dir;
  const devices::RoverConfig config =
      options.config ? *options.config : devices::parse_config(devices::default_virtual_rover_config(), parse);
  for (const std::string& name : options.devices) {
    const bool known = std::any_of(config.devices.begin(), config.devices.end(),
                                   [&](const devices::DeviceConfig& device) { return device.name == name; });
    if (!known) throw std::invalid_argument("no device named '" + name + "' in rover " + config.name);
  }

  transports::IoThread io;
  std::vector<std::shared_ptr<transports::FaultInjectingStream>> links;
  devices::Rover rover = demo::open_rover_with_fault_links(config, io.executor(), options.seed, links);

  BenchReport report;
  report.rover = config.name;
  report.tether_version = options.tether_version;
  report.seed = options.seed;
  report.iterations = options.duration ? 0 : options.iterations;
  if (options.duration) report.duration_s = std::chrono::duration<double>(*options.duration).count();
  report.isolated = options.isolated;
  report.reset = options.reset;
  report.saturation_ramp = options.saturation_ramp;
  report.workload = options.workload;
  report.payload = options.payload;
  report.bit_error_rates = options.bit_error_rates;
  report.rates = options.rates;

  std::vector<MeasuredDevice> measured;
  for (std::size_t k = 0; k < rover.devices().size(); ++k) {
    const devices::RoverDevice& device = rover.devices()[k];
    if (!options.devices.empty() &&
        std::find(options.devices.begin(), options.devices.end(), device.name) == options.devices.end()) {
      continue;
    }
    MeasuredDevice entry;
    entry.device = &device;
    entry.link = links[k];
    std::string why;
    entry.workload = make_bench_workload(device, config.devices[k], options.workload, options.payload, why);
    if (!entry.workload) {
      report.skipped.push_back({device.name, why});
      continue;
    }
    if (!device.boards.empty()) entry.witness = demo::ExecutionWitness::attach(*device.boards.back());
    if (const auto* serial = std::get_if<devices::SerialTransport>(&config.devices[k].transport)) {
      entry.serial_byte_seconds = 10.0 / static_cast<double>(serial->options.baud);  // start + 8 data + stop bits
    }
    DeviceSummary summary;
    summary.device = device.name;
    summary.codec = std::string(devices::to_string(device.codec));
    summary.transport = device.transport;
    summary.operation = entry.workload->operation();
    summary.confirmed = entry.workload->confirms();
    std::set<std::string> seen;
    for (const auto& board : device.boards) {
      const std::filesystem::path image = board->options().firmware;
      if (!seen.insert(image.string()).second) continue;
      std::string error;
      if (auto described = describe_firmware(image, error)) summary.firmware.push_back(std::move(*described));
    }
    report.devices.push_back(std::move(summary));
    measured.push_back(std::move(entry));
  }

  if (measured.empty()) {
    rover.close();
    std::string why;
    for (const BenchReport::Skipped& device : report.skipped) why += "; " + device.device + ": " + device.why;
    throw std::invalid_argument(std::string("no selected device has the ") + to_string(options.workload) +
                                " workload with the " + to_string(options.payload) + " payload" + why);
  }

  // The background: every device idle for a while, all at once.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> idle_before;
  for (const MeasuredDevice& entry : measured) idle_before.emplace_back(awake_cycles(*entry.device), all_cycles(*entry.device));
  std::this_thread::sleep_for(options.idle_baseline);
  for (std::size_t k = 0; k < measured.size(); ++k) {
    const std::uint64_t cycles = all_cycles(*measured[k].device) - idle_before[k].second;
    if (cycles == 0) continue;  // hardware
    measured[k].idle_share = static_cast<double>(awake_cycles(*measured[k].device) - idle_before[k].first) /
                             static_cast<double>(cycles);
    report.devices[k].cpu_idle_share = measured[k].idle_share;
  }

  const std::size_t total = options.bit_error_rates.size() * options.rates.size() * measured.size();
  std::size_t done = 0;
  std::mutex mutex;
  std::exception_ptr first_exception;
  const auto finished_one = [&] {
    std::lock_guard lock(mutex);
    ++done;
    if (options.progress) options.progress(done, total);
  };
  for (const double ber : options.bit_error_rates) {
    for (const std::optional<double>& rate : options.rates) {
      std::vector<PointResult> results(measured.size());
      if (options.isolated) {
        for (std::size_t k = 0; k < measured.size(); ++k) {
          results[k] = run_point(options, measured[k], ber, rate);
          finished_one();
        }
      } else {
        std::vector<std::thread> threads;
        for (std::size_t k = 0; k < measured.size(); ++k) {
          threads.emplace_back([&, k] {
            try {
              results[k] = run_point(options, measured[k], ber, rate);
            } catch (...) {
              std::lock_guard lock(mutex);
              if (!first_exception) first_exception = std::current_exception();
            }
            finished_one();
          });
        }
        for (std::thread& thread : threads) thread.join();
        if (first_exception) {
          rover.close();
          std::rethrow_exception(first_exception);
        }
      }
      for (PointResult& result : results) report.points.push_back(std::move(result));
    }
  }
  summarise_saturation(report);
  if (options.saturation_ramp) {
    // Each device ramps on its own (a device that breaks down early stops while the others go on).
    const auto ramp_device = [&](std::size_t k) {
      for (const double ber : options.bit_error_rates) ramp_saturation(options, measured[k], ber, report.devices[k]);
    };
    if (options.isolated) {
      for (std::size_t k = 0; k < measured.size(); ++k) ramp_device(k);
    } else {
      std::vector<std::thread> threads;
      for (std::size_t k = 0; k < measured.size(); ++k) {
        threads.emplace_back([&, k] {
          try {
            ramp_device(k);
          } catch (...) {
            std::lock_guard lock(mutex);
            if (!first_exception) first_exception = std::current_exception();
          }
        });
      }
      for (std::thread& thread : threads) thread.join();
      if (first_exception) {
        rover.close();
        std::rethrow_exception(first_exception);
      }
    }
  }
  measured.clear();
  rover.close();
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - started).count();
  return report;
}

}  // namespace tether::bench
