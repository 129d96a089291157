/// @file serial_port_stream.hpp
/// A serial port (USB CDC, FTDI, pty) as a ByteStream: raw 8N1, any standard baud, exclusive access,
/// optional low latency, and boot handling for boards that reset when the port opens.
///
/// An Arduino Uno resets when DTR rises, which Linux does on every open. The board then runs its
/// bootloader (about 0.5-1.5 s) before the sketch starts, and bytes sent meanwhile are lost or land in the
/// bootloader. `SerialOptions::arduino_uno()` therefore waits for the boot, then discards whatever the
/// board printed so far (boot noise), or waits for a banner the firmware prints when ready. Options for
/// links without DTR (ptys, the virtual Uno, ser2net) skip all of that.
#pragma once

#include <boost/asio/serial_port.hpp>

#include <boost/asio/steady_timer.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "tether/transports/asio_object_stream.hpp"

namespace tether::transports {

/// How to open a serial port.
struct SerialOptions {
  unsigned baud = 115200;                        ///< Standard rates only (termios B-constants).
  bool exclusive = true;                         ///< TIOCEXCL: no second process opens the port.
  bool low_latency = false;                      ///< ASYNC_LOW_LATENCY where the driver supports it.
  bool hang_up_on_close = true;                  ///< HUPCL: drop DTR on close (the next open resets an Uno).
  std::chrono::milliseconds boot_wait{0};        ///< Wait after opening before the port is usable.
  std::string ready_banner;                      ///< If set: wait until the device printed this.
  std::chrono::milliseconds boot_timeout{5000};  ///< Limit of the wait for `ready_banner`.
  bool discard_boot_noise = true;                ///< Drop bytes received before the port became usable.

  /// An Arduino Uno that resets on open: 2 s boot wait, noise discarded.
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

  /// Constructed by `open` (public for std::make_shared).
  SerialPortStream(executor_type executor, std::string path, const SerialOptions& options);

 private:
  using OpenHandler = UniqueFunction<OpenSignature>;
  static void start_open(executor_type executor, const std::string& path, const SerialOptions& options,
                         OpenHandler handler);
  void configure(error_code& error);
  void after_boot_wait(OpenHandler handler);
  void await_banner(std::shared_ptr<std::string> seen, SteadyClock::time_point deadline, OpenHandler handler);

  asio::steady_timer boot_timer_{strand()};
  std::uint8_t banner_byte_ = 0;
  std::string path_;
  SerialOptions options_;
  bool low_latency_applied_ = false;
};

}  // namespace tether::transports
