/// @file boot_detection.hpp
/// Knowing when a board that resets on open (an Uno's DTR) has booted, instead of waiting a fixed time.
///
/// After an open, a board runs its bootloader (optiboot: 1 s, silent) and then the sketch's setup. A codec
/// whose firmware announces itself at boot says how to recognise that announcement (`BootSignature::
/// find_announcement`: the proxy's and rpc's ResetEvent frame); one whose firmware is silent gives a probe
/// (`probe`, the codec's cheapest request that never runs a handler) sent once the line has been quiet for
/// `silence` (the bootloader's window), again every `probe_interval`, until `probe_answered`. Either way
/// the wait is bounded: `SerialOptions::boot_wait` is the upper bound, after which the open falls back to
/// what a fixed wait does (noise dropped, port usable) and says so (`BootOutcome::upper_bound`).
///
/// `BootDetector` is the sans-I/O state machine (time is a parameter: unit tests drive it with a fake
/// clock); `SerialPortStream` runs it on the port at the first open and after every re-open.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

namespace tether::transports {

/// How a serial port stream waits for a board after opening it.
enum class BootMode {
  none,    ///< No waiting: the port is usable at once (ptys, boards without DTR reset); `boot_wait` unused.
  fixed,   ///< Wait `boot_wait`, then drop what the board printed meanwhile.
  detect,  ///< Wait for the codec's boot announcement or probe answer, at most `boot_wait` (then as `fixed`).
};

/// `none`, `fixed`, `detect`.
const char* to_string(BootMode mode);
/// The mode named `name` (`"detect"`), or nothing.
std::optional<BootMode> parse_boot_mode(std::string_view name);

/// What a codec's firmware does at boot, for `BootMode::detect` (a codec row's `boot`, devices/codecs.hpp).
struct BootSignature {
  /// For messages: `ResetEvent frame`, `probe #\r`.
  std::string name;
  /// Looks for the firmware's boot announcement, complete, in `received` (every byte since the open,
  /// the first ones dropped beyond `BootDetector::kWindow`): its offset (what follows it is kept for the
  /// client), or nothing. Unset: the firmware announces nothing.
  std::function<std::optional<std::size_t>(std::string_view received)> find_announcement;
  /// Bytes to send once the line has been quiet for `silence`; empty: no probe.
  std::string probe;
  /// Whether `received` (every byte since the first probe) holds the answer to the probe, complete. The
  /// answer is dropped, never seen by the client. Required with a probe.
  std::function<bool(std::string_view received)> probe_answered;
  /// Quiet time before the first probe: more than the bootloader's window (a probe sent into optiboot is
  /// taken as STK500 and lost, and every byte optiboot receives restarts its 1 s window).
  std::chrono::milliseconds silence{1000};
  /// Between probes that got no answer: more than the bootloader's window too, or probes keep it alive.
  std::chrono::milliseconds probe_interval{100};

  /// Whether there is anything to detect (an announcement or a probe).
  bool usable() const { return static_cast<bool>(find_announcement) || (!probe.empty() && probe_answered); }
};

/// How a port became usable after an open.
enum class BootOutcome {
  immediate,    ///< `BootMode::none`: no wait.
  waited,       ///< `BootMode::fixed`: the whole `boot_wait`.
  announced,    ///< The firmware's boot announcement arrived.
  probed,       ///< The probe was answered.
  upper_bound,  ///< `BootMode::detect` saw neither within `boot_wait`: fell back to the fixed wait's result.
};

/// `immediate`, `waited`, `announced`, `probed`, `upper bound`.
const char* to_string(BootOutcome outcome);

/// When and how a port became usable after its last open.
struct BootReport {
  BootMode mode = BootMode::none;             ///< The mode it was opened with.
  BootOutcome outcome = BootOutcome::immediate;  ///< How the wait ended.
  std::chrono::milliseconds ready_after{0};   ///< From the open to usable, measured on the steady clock.
  unsigned probes = 0;                        ///< Probes sent.
};

/// The detection state machine: fed the port's bytes and timer expiries, it says what to do next.
class BootDetector {
 public:
  /// Time point of the clock the caller measures with (the steady clock, or a test's).
  using TimePoint = std::chrono::steady_clock::time_point;
  /// Bytes kept for `find_announcement` (older ones are boot noise); also the most a client is handed.
  static constexpr std::size_t kWindow = 1024;

  /// What to do now.
  struct Step {
    /// The action.
    enum class Action {
      wait,   ///< Read on; call `on_timer` at `wake` if nothing arrives.
      probe,  ///< Send `BootSignature::probe`, then as `wait`.
      ready,  ///< Booted: hand `kept()` to the client first; `report()` says how.
      gave_up,  ///< The upper bound passed: drop everything (the fixed wait's result); `report()` says so.
    };
    Action action = Action::wait;  ///< The action.
    TimePoint wake{};              ///< wait / probe: when to call `on_timer`.
  };

  /// Starts a detection of `signature` (must be `usable()`; copied) with the upper bound `limit` at `opened`.
  BootDetector(const BootSignature& signature, std::chrono::milliseconds limit, TimePoint opened);

  /// The first step (at the open).
  Step start();
  /// Bytes arrived at `now`.
  Step on_bytes(std::string_view bytes, TimePoint now);
  /// The wake time of the last step came (or later).
  Step on_timer(TimePoint now);

  /// Once ready: the bytes from the announcement on (empty after a probe).
  const std::string& kept() const { return kept_; }
  /// Once ready or given up: the outcome, `ready_after`, probes sent.
  const BootReport& report() const { return report_; }
  /// Whether it is done (ready or given up).
  bool done() const { return done_; }

 private:
  Step next_wait(TimePoint now);
  Step finish(BootOutcome outcome, TimePoint now);

  BootSignature signature_;
  TimePoint opened_;
  TimePoint deadline_;
  TimePoint quiet_since_;
  TimePoint next_probe_;
  bool probing_ = false;
  bool done_ = false;
  std::string received_;     // since the open, the last kWindow bytes
  std::string since_probe_;  // since the first probe, the last kWindow bytes
  std::string kept_;
  BootReport report_;
};

}  // namespace tether::transports
