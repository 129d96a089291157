// Rendering of a demo report: the side-by-side table and JSON; see rover_demo.hpp.
#include <algorithm>
#include <cstdio>
#include <sstream>

#include "tether/demo/rover_demo.hpp"

namespace tether::demo {

namespace {

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

std::string per_operation(std::uint64_t bytes, std::uint32_t operations) {
  return operations == 0 ? "-" : fixed(static_cast<double>(bytes) / operations, 1);
}

std::string optional_count(const std::optional<std::uint32_t>& value) {
  return value ? std::to_string(*value) : "n/a";
}

// One exactly-once figure, "n/a" without a witness.
std::string witness_figure(const DeviceReport& d, std::uint64_t ExactlyOnce::*figure) {
  return d.exactly_once ? std::to_string((*d.exactly_once).*figure) : "n/a";
}

}  // namespace

nlohmann::json witness_json(const std::optional<ExactlyOnce>& figures) {
  if (!figures) return nullptr;
  return {{"commands", figures->commands},
          {"confirmed", figures->confirmed},
          {"executed", figures->executed},
          {"executed_twice", figures->executed_twice},
          {"executed_but_failed", figures->executed_but_failed},
          {"confirmed_not_executed", figures->confirmed_not_executed},
          {"executed_unsent", figures->executed_unsent},
          {"unobserved", figures->unobserved}};
}

std::string format_table(const DemoReport& report) {
  std::vector<std::string> labels = {"",
                                     "operations",
                                     "successes",
                                     "failures",
                                     "wrong answers",
                                     "wire bytes / op (to+from)",
                                     "latency p50 (ms)",
                                     "latency p99 (ms)",
                                     "latency max (ms)",
                                     "retries",
                                     "stale replies",
                                     "CRC / framing drops",
                                     "bits flipped by noise",
                                     "resets injected",
                                     "resets detected",
                                     "recovered after (ms)",
                                     "servo pins (D9, D10)",
                                     "device commands issued",
                                     "  confirmed to the caller",
                                     "  executed (witness)",
                                     "  executed twice",
                                     "  executed, reported failed",
                                     "  confirmed, not executed",
                                     "  executed, never sent",
                                     "  executions not logged"};
  std::vector<std::vector<std::string>> columns;
  for (const DeviceReport& d : report.devices) {
    std::vector<std::string> column;
    column.push_back(d.device + " (" + d.codec + ")");
    column.push_back(std::to_string(d.operations));
    column.push_back(std::to_string(d.successes));
    column.push_back(std::to_string(d.failures));
    column.push_back(std::to_string(d.wrong));
    column.push_back(per_operation(d.bytes_to_device + d.bytes_from_device, d.operations) + " (" +
                     per_operation(d.bytes_to_device, d.operations) + "+" +
                     per_operation(d.bytes_from_device, d.operations) + ")");
    column.push_back(fixed(d.latency_p50_ms, 1));
    column.push_back(fixed(d.latency_p99_ms, 1));
    column.push_back(fixed(d.latency_max_ms, 1));
    column.push_back(std::to_string(d.retries));
    column.push_back(std::to_string(d.stale));
    column.push_back(std::to_string(d.crc_errors) + " / " + std::to_string(d.framing_errors));
    column.push_back(std::to_string(d.bits_flipped));
    column.push_back(std::to_string(d.resets_injected));
    column.push_back(optional_count(d.resets_detected));
    column.push_back(d.recovery_ms            ? fixed(*d.recovery_ms, 0)
                     : !d.confirmed           ? "n/a (no acks)"
                     : d.resets_injected != 0 ? "never"
                                              : "-");
    column.push_back(d.pins_match ? (*d.pins_match ? "match" : "MISMATCH") : "n/a");
    for (const auto figure : {&ExactlyOnce::commands, &ExactlyOnce::confirmed, &ExactlyOnce::executed,
                              &ExactlyOnce::executed_twice, &ExactlyOnce::executed_but_failed,
                              &ExactlyOnce::confirmed_not_executed, &ExactlyOnce::executed_unsent,
                              &ExactlyOnce::unobserved}) {
      column.push_back(witness_figure(d, figure));
    }
    columns.push_back(std::move(column));
  }
  std::size_t label_width = 0;
  for (const std::string& label : labels) label_width = std::max(label_width, label.size());
  std::vector<std::size_t> widths;
  for (const auto& column : columns) {
    std::size_t width = 0;
    for (const std::string& cell : column) width = std::max(width, cell.size());
    widths.push_back(width);
  }

  std::ostringstream out;
  out << "tether demo: " << report.rover << ", ";
  if (report.duration.count() > 0) {
    out << "operations for " << fixed(static_cast<double>(report.duration.count()) / 1000, 0) << " s per device";
  } else {
    out << report.iterations << " operations per device";
  }
  out << ", bit error rate " << report.bit_error_rate;
  if (report.reset_every > 0) {
    out << ", a power cycle per virtual device every " << report.reset_every << " operations";
  } else if (report.reset_halfway && report.duration.count() == 0) {
    out << ", one power cycle per virtual device halfway";
  }
  out << " (" << fixed(report.wall_seconds, 1) << " s)\n\n";
  for (std::size_t row = 0; row < labels.size(); ++row) {
    out << labels[row] << std::string(label_width - labels[row].size(), ' ');
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const std::string& cell = columns[c][row];
      out << "  " << std::string(widths[c] - cell.size(), ' ') << cell;
    }
    out << '\n';
  }
  out << '\n';
  for (const DeviceReport& d : report.devices) {
    out << d.device << ": " << d.operation << "; " << d.transport << '\n';
    if (d.final_rewrites > 0) {
      out << "  last positions written again " << d.final_rewrites
          << " time(s) after the run, until the state stream showed them (the deployed host would not)\n";
    }
    if (!d.pins_detail.empty()) out << "  pins measured/expected: " << d.pins_detail << '\n';
    if (!d.first_error.empty()) out << "  first error: " << d.first_error << '\n';
    if (!d.failure_causes.empty()) {
      out << "  failures by cause:";
      const char* separator = " ";
      for (const auto& [cause, count] : d.failure_causes) {
        out << separator << cause << " x" << count;
        separator = ", ";
      }
      out << '\n';
    }
  }
  return out.str();
}

nlohmann::json to_json(const DemoReport& report) {
  nlohmann::json devices = nlohmann::json::array();
  for (const DeviceReport& d : report.devices) {
    nlohmann::json device = {
        {"device", d.device},
        {"codec", d.codec},
        {"transport", d.transport},
        {"operation", d.operation},
        {"confirmed", d.confirmed},
        {"operations", d.operations},
        {"successes", d.successes},
        {"failures", d.failures},
        {"wrong", d.wrong},
        {"bytes_to_device", d.bytes_to_device},
        {"bytes_from_device", d.bytes_from_device},
        {"bits_flipped", d.bits_flipped},
        {"latency_ms", {{"p50", d.latency_p50_ms}, {"p99", d.latency_p99_ms}, {"max", d.latency_max_ms}}},
        {"retries", d.retries},
        {"stale", d.stale},
        {"crc_errors", d.crc_errors},
        {"framing_errors", d.framing_errors},
        {"resyncs", d.resyncs},
        {"resets_injected", d.resets_injected},
        {"resets_detected", d.resets_detected ? nlohmann::json(*d.resets_detected) : nlohmann::json(nullptr)},
        {"recovery_ms", d.recovery_ms ? nlohmann::json(*d.recovery_ms) : nlohmann::json(nullptr)},
        {"final_rewrites", d.final_rewrites},
        {"pins_match", d.pins_match ? nlohmann::json(*d.pins_match) : nlohmann::json(nullptr)},
        {"pins_detail", d.pins_detail},
        {"first_error", d.first_error},
        {"failure_causes", d.failure_causes},
        {"exactly_once", witness_json(d.exactly_once)},
    };
    devices.push_back(std::move(device));
  }
  return {{"rover", report.rover},
          {"iterations", report.iterations},
          {"bit_error_rate", report.bit_error_rate},
          {"reset_halfway", report.reset_halfway},
          {"duration_ms", report.duration.count()},
          {"reset_every", report.reset_every},
          {"wall_seconds", report.wall_seconds},
          {"devices", std::move(devices)}};
}

std::string format_json(const DemoReport& report) {
  return to_json(report).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace tether::demo
