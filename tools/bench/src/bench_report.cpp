// Rendering of a bench report: bench.json, bench.csv, the terminal table, and two runs compared; see
// bench.hpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "tether/bench/bench.hpp"
#include "tether/demo/rover_demo.hpp"

namespace tether::bench {

namespace {

using nlohmann::json;

template <typename T>
json optional_json(const std::optional<T>& value) {
  return value ? json(*value) : json(nullptr);
}

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

std::string rate_text(const std::optional<double>& rate) { return rate ? fixed(*rate, 0) : "max"; }

double per_operation(std::uint64_t value, std::uint32_t operations) {
  return operations == 0 ? 0.0 : static_cast<double>(value) / operations;
}

json point_json(const PointResult& p) {
  json cdf = json::array();
  for (const auto& [ms, share] : p.latency_cdf) cdf.push_back({ms, share});
  return {
      {"device", p.device},
      {"workload", to_string(p.workload)},
      {"payload", to_string(p.payload)},
      {"bit_error_rate", p.bit_error_rate},
      {"rate_hz", optional_json(p.rate_hz)},
      {"operations", p.operations},
      {"successes", p.successes},
      {"failures", p.failures},
      {"wrong", p.wrong},
      {"success_percent", 100.0 * p.success_share()},
      {"seconds", p.seconds},
      {"throughput_hz", p.throughput_hz()},
      {"latency_ms", {{"p50", p.latency_p50_ms}, {"p90", p.latency_p90_ms}, {"p99", p.latency_p99_ms},
                      {"max", p.latency_max_ms}}},
      {"latency_cdf", std::move(cdf)},
      {"bytes_to_device", p.bytes_to_device},
      {"bytes_from_device", p.bytes_from_device},
      {"bytes_per_op_to_device", per_operation(p.bytes_to_device, p.operations)},
      {"bytes_per_op_from_device", per_operation(p.bytes_from_device, p.operations)},
      {"utilisation_to_device", optional_json(p.utilisation_to_device)},
      {"utilisation_from_device", optional_json(p.utilisation_from_device)},
      {"bits_flipped", p.bits_flipped},
      {"retries", p.retries},
      {"timeouts", p.timeouts},
      {"drops", {{"stale", p.stale}, {"crc", p.crc_errors}, {"framing", p.framing_errors}, {"oversize", p.oversize}}},
      {"cpu_cycles_per_op", optional_json(p.cpu_cycles_per_op)},
      {"cpu_cycles_per_op_above_idle", optional_json(p.cpu_cycles_per_op_above_idle)},
      {"cpu_share", optional_json(p.cpu_share)},
      {"resets_injected", p.resets_injected},
      {"resets_detected", optional_json(p.resets_detected)},
      {"recovery_ms", optional_json(p.recovery_ms)},
      {"exactly_once", demo::witness_json(p.exactly_once)},
      {"first_error", p.first_error},
  };
}

// --- compare ---------------------------------------------------------------------------------------------

const json& member(const json& object, const char* name, const std::string& where) {
  if (!object.is_object() || !object.contains(name)) throw std::invalid_argument(where + ": no \"" + name + "\"");
  return object.at(name);
}

double number(const json& object, const char* name, const std::string& where) {
  const json& value = member(object, name, where);
  if (!value.is_number()) throw std::invalid_argument(where + "." + name + ": expected a number");
  return value.get<double>();
}

std::optional<double> optional_number(const json& object, const char* name, const std::string& where) {
  const json& value = member(object, name, where);
  if (value.is_null()) return std::nullopt;
  if (!value.is_number()) throw std::invalid_argument(where + "." + name + ": expected a number or null");
  return value.get<double>();
}

// One point of a run, keyed by device, BER and rate.
struct ComparedPoint {
  double operations = 0;
  double success = 0;  // share
  double p50 = 0;
  double p90 = 0;
  double p99 = 0;
  double bytes_per_op = 0;
  std::optional<double> cpu_per_op;
};

using PointKey = std::tuple<std::string, double, std::string>;

std::map<PointKey, ComparedPoint> read_points(const json& run, const std::string& name) {
  const json& points = member(run, "points", name);
  if (!points.is_array()) throw std::invalid_argument(name + ".points: expected an array");
  std::map<PointKey, ComparedPoint> result;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const std::string where = name + ".points[" + std::to_string(k) + "]";
    const json& p = points[k];
    const json& device = member(p, "device", where);
    if (!device.is_string()) throw std::invalid_argument(where + ".device: expected a string");
    const std::optional<double> rate = optional_number(p, "rate_hz", where);
    ComparedPoint point;
    point.operations = number(p, "operations", where);
    point.success = point.operations > 0 ? number(p, "successes", where) / point.operations : 0.0;
    const json& latency = member(p, "latency_ms", where);
    point.p50 = number(latency, "p50", where + ".latency_ms");
    point.p90 = number(latency, "p90", where + ".latency_ms");
    point.p99 = number(latency, "p99", where + ".latency_ms");
    point.bytes_per_op = number(p, "bytes_per_op_to_device", where) + number(p, "bytes_per_op_from_device", where);
    point.cpu_per_op = optional_number(p, "cpu_cycles_per_op", where);
    // Points of different workloads or payloads are different measurements; a run without the fields
    // measured the demo's servo operation.
    std::string key_device = device.get<std::string>();
    if (p.contains("workload") && p["workload"].is_string() && p["workload"] != "servo") {
      key_device += " (" + p["workload"].get<std::string>() + ")";
    }
    if (p.contains("payload") && p["payload"].is_string() && p["payload"] != "demo") {
      key_device += " [" + p["payload"].get<std::string>() + "]";
    }
    result[{key_device, number(p, "bit_error_rate", where), rate_text(rate)}] = point;
  }
  return result;
}

// Run-to-run noise: a success share differs beyond chance when the gap exceeds three standard errors of
// the two binomial shares (plus one operation's worth); a latency percentile when it moves by more than
// 25 % and 1 ms (scheduling on a loaded host moves single runs by that much); bytes and CPU per operation
// (deterministic but for retries) by more than 5 %.
bool success_differs(const ComparedPoint& a, const ComparedPoint& b) {
  if (a.operations <= 0 || b.operations <= 0) return a.operations != b.operations;
  const double pooled = (a.success * a.operations + b.success * b.operations) / (a.operations + b.operations);
  const double error = std::sqrt(pooled * (1 - pooled) * (1 / a.operations + 1 / b.operations));
  return std::abs(a.success - b.success) > 3 * error + 1 / std::min(a.operations, b.operations);
}
bool latency_differs(double a, double b) { return std::abs(a - b) > std::max(1.0, 0.25 * std::min(a, b)); }
bool amount_differs(double a, double b) { return std::abs(a - b) > 0.05 * std::max(std::abs(a), std::abs(b)); }

}  // namespace

json to_json(const BenchReport& report) {
  json devices = json::array();
  for (const DeviceSummary& d : report.devices) {
    json firmware = json::array();
    for (const FirmwareImage& image : d.firmware) {
      firmware.push_back({{"path", image.path}, {"sha256", image.sha256}, {"flash_bytes", image.flash_bytes},
                          {"ram_bytes", image.ram_bytes}});
    }
    json saturation = json::array();
    for (const DeviceSummary::Saturation& s : d.saturation) {
      json ramp = json::array();
      for (const DeviceSummary::Saturation::RampStep& step : s.ramp) {
        ramp.push_back({{"rate_hz", step.rate_hz}, {"achieved_hz", step.achieved_hz}, {"operations", step.operations},
                        {"successes", step.successes}, {"latency_p99_ms", step.latency_p99_ms},
                        {"sustained", step.sustained}});
      }
      saturation.push_back({{"bit_error_rate", s.bit_error_rate}, {"sustained_hz", optional_json(s.sustained_hz)},
                            {"breaks_down_hz", optional_json(s.breaks_down_hz)},
                            {"source", s.ramp.empty() ? "sweep" : "ramp"}, {"ramp", std::move(ramp)},
                            {"breaks_down_because", s.breaks_down_because}});
    }
    devices.push_back({{"device", d.device},
                       {"codec", d.codec},
                       {"transport", d.transport},
                       {"operation", d.operation},
                       {"confirmed", d.confirmed},
                       {"cpu_idle_share", optional_json(d.cpu_idle_share)},
                       {"firmware", std::move(firmware)},
                       {"saturation", std::move(saturation)}});
  }
  json points = json::array();
  for (const PointResult& p : report.points) points.push_back(point_json(p));
  json skipped = json::array();
  for (const BenchReport::Skipped& device : report.skipped) skipped.push_back({{"device", device.device}, {"why", device.why}});
  json rates = json::array();
  for (const auto& rate : report.rates) rates.push_back(rate ? json(*rate) : json("max"));
  return {{"tether_version", report.tether_version},
          {"rover", report.rover},
          {"parameters",
           {{"seed", report.seed},
            {"iterations", report.iterations},
            {"duration_s", optional_json(report.duration_s)},
            {"isolated", report.isolated},
            {"reset", report.reset},
            {"bit_error_rates", report.bit_error_rates},
            {"rates_hz", std::move(rates)},
            {"sustained_success", kSustainedSuccess},
            {"workload", to_string(report.workload)},
            {"payload", to_string(report.payload)},
            {"saturation_ramp", report.saturation_ramp},
            {"sustained_throughput", kSustainedThroughput}}},
          {"wall_seconds", report.wall_seconds},
          {"devices", std::move(devices)},
          {"points", std::move(points)},
          {"skipped", std::move(skipped)}};
}

std::string to_csv(const BenchReport& report) {
  std::ostringstream out;
  out << "device,codec,bit_error_rate,rate_hz,operations,successes,failures,wrong,success_percent,seconds,"
         "throughput_hz,latency_p50_ms,latency_p90_ms,latency_p99_ms,latency_max_ms,bytes_to_device,"
         "bytes_from_device,bytes_per_op_to_device,bytes_per_op_from_device,utilisation_to_device,"
         "utilisation_from_device,bits_flipped,retries,timeouts,drops_stale,drops_crc,drops_framing,drops_oversize,"
         "cpu_cycles_per_op,cpu_cycles_per_op_above_idle,cpu_share,resets_injected,resets_detected,recovery_ms,commands,confirmed,executed,executed_twice,"
         "executed_but_failed,confirmed_not_executed,executed_unsent,workload,payload\n";
  const auto optional_text = [](const auto& value) {
    if (!value) return std::string();
    std::ostringstream text;
    text.precision(10);
    text << *value;
    return text.str();
  };
  out.precision(10);
  for (const PointResult& p : report.points) {
    std::string codec;
    for (const DeviceSummary& d : report.devices) {
      if (d.device == p.device) codec = d.codec;
    }
    // Device names come from the config: quote them (doubling quotes) so a comma cannot shift columns.
    std::string name = "\"";
    for (const char c : p.device) name += c == '"' ? std::string("\"\"") : std::string(1, c);
    name += '"';
    out << name << ',' << codec << ',' << p.bit_error_rate << ',' << (p.rate_hz ? optional_text(p.rate_hz) : "max")
        << ',' << p.operations << ',' << p.successes << ',' << p.failures << ',' << p.wrong << ','
        << 100.0 * p.success_share() << ',' << p.seconds << ',' << p.throughput_hz() << ',' << p.latency_p50_ms << ','
        << p.latency_p90_ms << ',' << p.latency_p99_ms << ',' << p.latency_max_ms << ',' << p.bytes_to_device << ','
        << p.bytes_from_device << ',' << per_operation(p.bytes_to_device, p.operations) << ','
        << per_operation(p.bytes_from_device, p.operations) << ',' << optional_text(p.utilisation_to_device) << ','
        << optional_text(p.utilisation_from_device) << ',' << p.bits_flipped << ',' << p.retries << ',' << p.timeouts
        << ',' << p.stale << ',' << p.crc_errors << ',' << p.framing_errors << ',' << p.oversize << ','
        << optional_text(p.cpu_cycles_per_op) << ',' << optional_text(p.cpu_cycles_per_op_above_idle) << ','
        << optional_text(p.cpu_share) << ',' << p.resets_injected << ','
        << optional_text(p.resets_detected) << ',' << optional_text(p.recovery_ms);
    const auto witness = [&](std::uint64_t demo::ExactlyOnce::*figure) {
      return p.exactly_once ? std::to_string((*p.exactly_once).*figure) : std::string();
    };
    for (const auto figure : {&demo::ExactlyOnce::commands, &demo::ExactlyOnce::confirmed, &demo::ExactlyOnce::executed,
                              &demo::ExactlyOnce::executed_twice, &demo::ExactlyOnce::executed_but_failed,
                              &demo::ExactlyOnce::confirmed_not_executed, &demo::ExactlyOnce::executed_unsent}) {
      out << ',' << witness(figure);
    }
    out << ',' << to_string(p.workload) << ',' << to_string(p.payload) << '\n';
  }
  return out.str();
}

std::string format_table(const BenchReport& report) {
  std::ostringstream out;
  out << "tether bench: " << report.rover << ", "
      << (report.duration_s ? fixed(*report.duration_s, 1) + " s" : std::to_string(report.iterations) + " operations")
      << " per device and point, " << (report.isolated ? "one device at a time" : "all devices at once")
      << (report.reset ? ", a power cycle halfway" : "") << ", seed " << report.seed << ", workload "
      << to_string(report.workload) << ", payload " << to_string(report.payload) << " ("
      << fixed(report.wall_seconds, 1) << " s)\n\n";
  for (const BenchReport::Skipped& device : report.skipped) out << device.device << ": skipped, " << device.why << '\n';
  if (!report.skipped.empty()) out << '\n';
  char line[256];
  std::snprintf(line, sizeof line, "%-12s %8s %5s %5s %8s %7s %7s %7s %7s %7s %6s %6s %9s %9s\n", "device", "BER",
                "rate", "ops", "success%", "wrong", "p50ms", "p99ms", "maxms", "B/op", "retry", "drops", "cyc/op",
                "twice/lost");
  out << line;
  for (const PointResult& p : report.points) {
    char ber[32];
    std::snprintf(ber, sizeof ber, "%g", p.bit_error_rate);
    // Exactly-once: commands executed twice / confirmed but never executed.
    const std::string witness = p.exactly_once ? std::to_string(p.exactly_once->executed_twice) + "/" +
                                                     std::to_string(p.exactly_once->confirmed_not_executed)
                                               : "-";
    std::snprintf(line, sizeof line, "%-12.12s %8s %5s %5u %8.1f %7u %7.1f %7.1f %7.1f %7.1f %6u %6u %9s %9s\n",
                  p.device.c_str(), ber, rate_text(p.rate_hz).c_str(), p.operations, 100.0 * p.success_share(),
                  p.wrong, p.latency_p50_ms, p.latency_p99_ms, p.latency_max_ms,
                  per_operation(p.bytes_to_device + p.bytes_from_device, p.operations), p.retries,
                  p.stale + p.crc_errors + p.framing_errors + p.oversize,
                  p.cpu_cycles_per_op ? fixed(*p.cpu_cycles_per_op, 0).c_str() : "-", witness.c_str());
    out << line;
  }
  out << '\n';
  for (const DeviceSummary& d : report.devices) {
    out << d.device << " (" << d.codec << "): " << d.operation << "; " << d.transport << '\n';
    for (const FirmwareImage& image : d.firmware) {
      out << "  firmware " << image.path << ": " << image.flash_bytes << " bytes flash, " << image.ram_bytes
          << " bytes RAM, sha256 " << image.sha256.substr(0, 16) << "...\n";
    }
    for (const DeviceSummary::Saturation& s : d.saturation) {
      char ber[32];
      std::snprintf(ber, sizeof ber, "%g", s.bit_error_rate);
      out << "  BER " << ber << ": sustained (>= 99 % success) "
          << (s.sustained_hz ? fixed(*s.sustained_hz, 1) + " op/s" : std::string("at no rate"))
          << (s.breaks_down_hz ? ", breaks down at " + rate_text(s.breaks_down_hz) + " op/s" : std::string())
          << (s.breaks_down_because.empty() ? std::string() : " (" + s.breaks_down_because + ")")
          << (s.ramp.empty() ? std::string() : " [ramp of " + std::to_string(s.ramp.size()) + " step(s)]") << '\n';
    }
  }
  return out.str();
}

Comparison compare(const json& a, const json& b) {
  const auto points_a = read_points(a, "A");
  const auto points_b = read_points(b, "B");
  Comparison result;
  result.json = json::array();
  std::ostringstream out;
  char line[320];
  std::snprintf(line, sizeof line, "%-12s %8s %5s | %17s | %17s | %17s | %17s | %19s\n", "device", "BER", "rate",
                "success % A/B", "p50 ms A/B", "p99 ms A/B", "bytes/op A/B", "cycles/op A/B");
  out << line;
  std::size_t common = 0;
  for (const auto& [key, pa] : points_a) {
    const auto found = points_b.find(key);
    if (found == points_b.end()) continue;
    ++common;
    const ComparedPoint& pb = found->second;
    const bool success = success_differs(pa, pb);
    const bool p50 = latency_differs(pa.p50, pb.p50);
    const bool p99 = latency_differs(pa.p99, pb.p99);
    const bool bytes = amount_differs(pa.bytes_per_op, pb.bytes_per_op);
    const bool cpu = pa.cpu_per_op && pb.cpu_per_op ? amount_differs(*pa.cpu_per_op, *pb.cpu_per_op)
                                                    : pa.cpu_per_op.has_value() != pb.cpu_per_op.has_value();
    result.flagged += static_cast<std::size_t>(success) + static_cast<std::size_t>(p50) + static_cast<std::size_t>(p99) +
                      static_cast<std::size_t>(bytes) + static_cast<std::size_t>(cpu);
    const auto pair = [](double x, double y, int decimals, bool flag) {
      return fixed(x, decimals) + " / " + fixed(y, decimals) + (flag ? " *" : "  ");
    };
    const auto& [device, ber, rate] = key;
    char ber_text[32];
    std::snprintf(ber_text, sizeof ber_text, "%g", ber);
    std::snprintf(line, sizeof line, "%-12.12s %8s %5s | %17s | %17s | %17s | %17s | %19s\n", device.c_str(), ber_text,
                  rate.c_str(), pair(100 * pa.success, 100 * pb.success, 1, success).c_str(),
                  pair(pa.p50, pb.p50, 1, p50).c_str(), pair(pa.p99, pb.p99, 1, p99).c_str(),
                  pair(pa.bytes_per_op, pb.bytes_per_op, 1, bytes).c_str(),
                  (pa.cpu_per_op && pb.cpu_per_op ? pair(*pa.cpu_per_op, *pb.cpu_per_op, 0, cpu)
                                                  : std::string(cpu ? "- *" : "-"))
                      .c_str());
    out << line;
    result.json.push_back({{"device", device},
                           {"bit_error_rate", ber},
                           {"rate", rate},
                           {"success_percent", {100 * pa.success, 100 * pb.success}},
                           {"latency_p50_ms", {pa.p50, pb.p50}},
                           {"latency_p99_ms", {pa.p99, pb.p99}},
                           {"bytes_per_op", {pa.bytes_per_op, pb.bytes_per_op}},
                           {"cpu_cycles_per_op", {optional_json(pa.cpu_per_op), optional_json(pb.cpu_per_op)}},
                           {"flagged",
                            {{"success", success}, {"latency_p50", p50}, {"latency_p99", p99}, {"bytes_per_op", bytes},
                             {"cpu_cycles_per_op", cpu}}}});
  }
  if (common == 0) throw std::invalid_argument("the two runs have no point (device, BER, rate) in common");
  out << '\n'
      << (result.flagged == 0 ? std::string("no differences beyond run-to-run noise")
                              : std::to_string(result.flagged) + " difference(s) beyond run-to-run noise (marked *)")
      << "; " << common << " point(s) in common, " << points_a.size() - common << " only in A, "
      << points_b.size() - common << " only in B\n";
  result.text = out.str();
  return result;
}

}  // namespace tether::bench
