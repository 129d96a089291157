/// @file serial_port_stream.hpp
/// A serial port (USB CDC, FTDI, pty) as a ByteStream: raw 8N1, any standard baud, exclusive access,
/// optional low latency, and boot handling for boards that reset when the port opens.
///
/// An Arduino Uno resets when DTR rises, which Linux does on every open. The board then runs its
/// bootloader (about 0.5-1.5 s) before the sketch starts, and bytes sent meanwhile are lost or land in the
/// bootloader. `SerialOptions::boot` says how the open waits for it: `BootMode::fixed` waits `boot_wait`
/// and then discards whatever the board printed so far (boot noise); `BootMode::detect` completes as soon
/// as the codec's `BootSignature` (boot_detection.hpp) says the sketch runs (its boot announcement, or the
/// answer to a probe sent after the bootloader's quiet window), `boot_wait` being the upper bound after
/// which it falls back to the fixed wait's result; `BootMode::none` does not wait. A `ready_banner` may
/// be awaited on top. `boot_report()` says how long the board took. Options for links without DTR (ptys,
/// the virtual Uno, ser2net) skip all of that.
///
/// ## Supervision (`SerialOptions::reconnect`, on by default)
/// A port that vanishes (unplugged: EOF, EIO, ENODEV on a read or write) does not end the stream. The
/// pending read completes with `TransportError::disconnected` (writes too, and every write until the port
/// is back), the stream closes the port and tries to re-open it: the same `PortSpec` looked up again (a
/// board named by identity may come back under another path), after 50 ms, then backing off to at most
/// `ReconnectOptions::max_delay` (1 s) between attempts, forever or up to `max_attempts`. Re-opened, it
/// configures the port and waits for the boot as at the first open (`boot`, `boot_wait`), then the
/// next read completes with `TransportError::reconnected` (no bytes), before any byte of the new
/// connection: a client's cue to run its session recovery. Having given up, reads and writes fail with
/// `TransportError::reconnect_limit`. Link events (down with its reason, up with the outage's length and
/// the boot's report, gave up) go to the handlers of `add_link_handler`; `link_counters()` counts them. A
/// `ready_banner` is awaited only at the first open. Reads and writes stay ordered and bounded; nothing is
/// retried by the stream.
#pragma once

#include <boost/asio/serial_port.hpp>

#include <boost/asio/steady_timer.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "tether/transports/asio_object_stream.hpp"
#include "tether/transports/boot_detection.hpp"
#include "tether/transports/serial_ports.hpp"

namespace tether::transports {

/// How a serial port stream re-opens a port that vanished (see "Supervision" above).
struct ReconnectOptions {
  bool enabled = true;                            ///< Off: a vanished port ends the stream (EOF, EIO).
  std::chrono::milliseconds first_delay{50};      ///< Wait before the first attempt (> 0).
  std::chrono::milliseconds max_delay{1000};      ///< The backoff (doubling) stops growing here (>= first_delay).
  unsigned max_attempts = 0;                      ///< Attempts per outage before giving up; 0: forever.
};

/// A change of a supervised port's link.
struct LinkEvent {
  /// What happened.
  enum class Kind {
    down,     ///< The port vanished; `reason` says how (`/dev/ttyACM0: Input/output error`).
    up,       ///< Re-opened (at `path`) after `down_for`.
    gave_up,  ///< `max_attempts` failed; `reason` is the last failure. The stream is done.
  };
  Kind kind = Kind::down;              ///< What happened.
  std::string reason;                  ///< down / gave_up: why.
  std::string path;                    ///< The port's path (up: the new one).
  std::chrono::milliseconds down_for{0};  ///< up / gave_up: how long the link was down.
  unsigned attempts = 0;               ///< up / gave_up: re-open attempts this outage.
  BootReport boot;                     ///< up: how the board came up after the re-open.
};

/// `down`, `up`, `gave up`: for messages.
const char* to_string(LinkEvent::Kind kind);

/// Counts of a supervised port's outages since it opened.
struct LinkCounters {
  std::uint64_t disconnects = 0;          ///< Times the port vanished.
  std::uint64_t reconnects = 0;           ///< Times it was re-opened.
  std::chrono::milliseconds time_down{0};  ///< Total time without the port (the current outage included).
  bool up = true;                         ///< False during an outage and after giving up.
  bool gave_up = false;                   ///< The reconnect limit was reached: the stream is done.
  BootReport last_boot;                   ///< The last open's (first or re-open) time to ready and how.
};

/// How to open a serial port.
struct SerialOptions {
  unsigned baud = 115200;                        ///< Standard rates only (termios B-constants).
  bool exclusive = true;                         ///< TIOCEXCL: no second process opens the port.
  bool low_latency = false;                      ///< ASYNC_LOW_LATENCY where the driver supports it.
  bool hang_up_on_close = true;                  ///< HUPCL: drop DTR on close (the next open resets an Uno).
  BootMode boot = BootMode::fixed;               ///< How to wait for the board after an open (file comment).
  std::chrono::milliseconds boot_wait{0};        ///< fixed: the wait; detect: its upper bound; 0: none.
  BootSignature boot_signature;                  ///< detect: the firmware's (a codec row's `boot`); unusable: fixed.
  std::string ready_banner;                      ///< If set: wait until the device printed this.
  std::chrono::milliseconds boot_timeout{5000};  ///< Limit of the wait for `ready_banner`.
  bool discard_boot_noise = true;                ///< Drop bytes received before the port became usable.
  ReconnectOptions reconnect;                    ///< Re-open a port that vanished (on by default).

  /// An Arduino Uno that resets on open: 2 s fixed boot wait, noise discarded (a codec's signature and
  /// `BootMode::detect` shorten it: devices/codecs.hpp).
  static SerialOptions arduino_uno() {
    SerialOptions options;
    options.boot_wait = std::chrono::milliseconds(2000);
    return options;
  }
};

/// Serial port stream; create with `async_open` or `open`.
class SerialPortStream final : public AsioObjectStream<asio::serial_port> {
 public:
  /// Completion signature of `async_open`.
  using OpenSignature = void(error_code, std::shared_ptr<SerialPortStream>);

  /// Opens and configures `path`, then performs the boot handling of `options` (boot wait, noise
  /// discard, ready banner) asynchronously. Completes with the stream, or with an error and null: OS
  /// errors (ENOENT, EACCES, EBUSY when exclusive), `TransportError::invalid_option` (baud),
  /// `TransportError::boot_timeout` (banner not seen).
  template <typename OpenToken>
  static auto async_open(executor_type executor, const std::string& path, const SerialOptions& options,
                         OpenToken&& token) {
    return asio::async_initiate<OpenToken, OpenSignature>(
        [](auto handler, executor_type target, const std::string& device, const SerialOptions& settings) {
          auto bound = bind_to_associated_executor<OpenSignature>(std::move(handler), target);
          start_open(std::move(target), device, settings, std::move(bound));
        },
        token, std::move(executor), path, options);
  }

  /// `async_open` of the port `port` names: its path, or the one port with its identity (looked up now and
  /// after every outage, serial_ports.hpp). A lookup that fails completes with
  /// `TransportError::no_matching_port` / `several_matching_ports` (`resolve_port` says which ports it saw).
  template <typename OpenToken>
  static auto async_open(executor_type executor, const PortSpec& port, const SerialOptions& options,
                         OpenToken&& token) {
    return asio::async_initiate<OpenToken, OpenSignature>(
        [](auto handler, executor_type target, const PortSpec& spec, const SerialOptions& settings) {
          auto bound = bind_to_associated_executor<OpenSignature>(std::move(handler), target);
          start_open(std::move(target), spec, settings, std::move(bound));
        },
        token, std::move(executor), port, options);
  }

  /// Blocking `async_open`; needs another thread running the executor (like every blocking call).
  static std::shared_ptr<SerialPortStream> open(executor_type executor, const std::string& path,
                                                const SerialOptions& options, error_code& error);
  /// Throwing variant of `open`.
  static std::shared_ptr<SerialPortStream> open(executor_type executor, const std::string& path,
                                                const SerialOptions& options = SerialOptions());

  std::string description() const override;
  /// The options the port was opened with.
  const SerialOptions& options() const { return options_; }
  /// Whether the driver accepted the low-latency request.
  bool low_latency_applied() const { return low_latency_applied_; }
  /// The port's current path (it may change after an outage when the port is named by identity). Any thread.
  std::string path() const;

  /// Adds a handler of link events (supervision). Runs on the stream's strand: it must not block; it may
  /// call the stream's thread-safe getters. Any thread; add handlers before the port can vanish to see
  /// every event.
  void add_link_handler(std::function<void(const LinkEvent&)> handler);
  /// The outage counters. Any thread.
  LinkCounters link_counters() const;
  /// How the board came up after the last open (first or re-open). Any thread.
  BootReport boot_report() const;

  /// Constructed by `open` (public for std::make_shared).
  SerialPortStream(executor_type executor, std::string path, const SerialOptions& options);

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override;
  void do_write(asio::const_buffer buffer, IoHandler handler) override;
  void do_close(error_code& error) override;

 private:
  using OpenHandler = UniqueFunction<OpenSignature>;
  struct ParkedRead {
    IoHandler handler;
  };
  static void start_open(executor_type executor, const std::string& path, const SerialOptions& options,
                         OpenHandler handler);
  static void start_open(executor_type executor, const PortSpec& port, const SerialOptions& options,
                         OpenHandler handler);
  using BootHandler = UniqueFunction<void(error_code)>;
  void configure(error_code& error);
  void boot(SteadyClock::time_point opened, BootHandler done);
  void boot_read();
  void boot_apply(BootDetector::Step step);
  void boot_finish(BootReport report, const error_code& error);  // by value: it may be the detector's, reset here
  void after_boot_wait(OpenHandler handler);
  void await_banner(std::shared_ptr<std::string> seen, SteadyClock::time_point deadline, OpenHandler handler);
  // Supervision (strand).
  bool supervised() const { return options_.reconnect.enabled; }
  void on_io_error(std::uint64_t connection, const error_code& error);
  void lose(const error_code& error);
  void schedule_attempt();
  void attempt();
  void retry_later(std::string reason);
  void become_up();
  void emit(const LinkEvent& event);
  void owe(const error_code& notice);

  asio::steady_timer boot_timer_{strand()};
  std::uint8_t banner_byte_ = 0;
  SerialOptions options_;
  bool low_latency_applied_ = false;
  PortSpec spec_;  // what to look up again after an outage

  // Strand only.
  asio::steady_timer retry_timer_{strand()};
  std::uint64_t connection_ = 0;  // bumped when the port is lost: completions of the old one are told apart
  bool down_ = false;
  bool read_in_flight_ = false;
  bool closing_ = false;
  error_code gave_up_;
  std::unique_ptr<ParkedRead> parked_;
  std::deque<error_code> owed_;  // notices for the next reads, when none was in flight to carry them
  unsigned attempts_ = 0;
  std::chrono::milliseconds delay_{0};
  std::string last_failure_;
  // Boot detection (strand).
  std::unique_ptr<BootDetector> detector_;
  BootHandler boot_done_;
  std::uint64_t boot_generation_ = 0;  // tells the completions of a finished detection apart
  std::array<std::uint8_t, 256> boot_buffer_{};
  std::string replay_;  // bytes the detection read past the announcement: the first the client reads

  // Any thread.
  mutable std::mutex mutex_;
  std::string path_;
  LinkCounters counters_;
  SteadyClock::time_point down_since_;
  bool outage_running_ = false;
  std::vector<std::function<void(const LinkEvent&)>> handlers_;
};

}  // namespace tether::transports
