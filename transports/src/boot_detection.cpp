#include "tether/transports/boot_detection.hpp"

#include <algorithm>

namespace tether::transports {

const char* to_string(BootMode mode) {
  switch (mode) {
    case BootMode::none: return "none";
    case BootMode::fixed: return "fixed";
    case BootMode::detect: return "detect";
  }
  return "unknown";
}

std::optional<BootMode> parse_boot_mode(std::string_view name) {
  for (const BootMode mode : {BootMode::none, BootMode::fixed, BootMode::detect}) {
    if (name == to_string(mode)) return mode;
  }
  return std::nullopt;
}

const char* to_string(BootOutcome outcome) {
  switch (outcome) {
    case BootOutcome::immediate: return "immediate";
    case BootOutcome::waited: return "waited";
    case BootOutcome::announced: return "announced";
    case BootOutcome::probed: return "probed";
    case BootOutcome::upper_bound: return "upper bound";
  }
  return "unknown";
}

namespace {

void append_bounded(std::string& into, std::string_view bytes) {
  into.append(bytes);
  if (into.size() > BootDetector::kWindow) into.erase(0, into.size() - BootDetector::kWindow);
}

}  // namespace

BootDetector::BootDetector(const BootSignature& signature, std::chrono::milliseconds limit, TimePoint opened)
    : signature_(signature), opened_(opened), deadline_(opened + limit), quiet_since_(opened) {
  report_.mode = BootMode::detect;
}

BootDetector::Step BootDetector::start() { return next_wait(opened_); }

BootDetector::Step BootDetector::on_bytes(std::string_view bytes, TimePoint now) {
  if (done_) return Step{Step::Action::ready, now};
  quiet_since_ = now;  // the line is not quiet: a probe waits for silence again
  append_bounded(received_, bytes);
  if (signature_.find_announcement) {
    if (const auto offset = signature_.find_announcement(received_)) {
      kept_ = received_.substr(std::min(*offset, received_.size()));
      return finish(BootOutcome::announced, now);
    }
  }
  if (probing_) {
    append_bounded(since_probe_, bytes);
    if (signature_.probe_answered(since_probe_)) return finish(BootOutcome::probed, now);
  }
  return next_wait(now);
}

BootDetector::Step BootDetector::on_timer(TimePoint now) {
  if (done_) return Step{Step::Action::ready, now};
  if (now >= deadline_) return finish(BootOutcome::upper_bound, now);
  const bool can_probe = !signature_.probe.empty() && signature_.probe_answered;
  // The first probe after `silence` of quiet (the bootloader's window), the next ones every interval.
  if (can_probe && (probing_ ? now >= next_probe_ : now >= quiet_since_ + signature_.silence)) {
    probing_ = true;
    ++report_.probes;
    next_probe_ = now + std::max(signature_.probe_interval, std::chrono::milliseconds(1));
    Step step = next_wait(now);
    step.action = Step::Action::probe;
    return step;
  }
  return next_wait(now);
}

BootDetector::Step BootDetector::next_wait(TimePoint now) {
  TimePoint wake = deadline_;
  if (!signature_.probe.empty() && signature_.probe_answered) {
    const TimePoint due = probing_ ? next_probe_ : quiet_since_ + signature_.silence;
    wake = std::min(wake, std::max(due, now));
  }
  return Step{Step::Action::wait, wake};
}

BootDetector::Step BootDetector::finish(BootOutcome outcome, TimePoint now) {
  done_ = true;
  report_.outcome = outcome;
  report_.ready_after = std::chrono::duration_cast<std::chrono::milliseconds>(now - opened_);
  if (outcome == BootOutcome::upper_bound) kept_.clear();
  return Step{outcome == BootOutcome::upper_bound ? Step::Action::gave_up : Step::Action::ready, now};
}

}  // namespace tether::transports
