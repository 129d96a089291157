/// @file rover.hpp
/// Opens every device of a `RoverConfig` (config.hpp) in one call and hands out typed clients by name.
///
/// @code
///   transports::IoThread io;                                           // or any thread running an io_context
///   devices::Rover rover = devices::open_rover(config, io.executor());  // throws devices::ConfigError
///   rover.client<romi::Client>("arm")->call("L[1]");                 // tether/romi/client.hpp
///   rover.client<proxy::Client>("servos")->servo(9).set(120);        // tether/proxy/client.hpp
///   for (const devices::RoverDevice& device : rover.devices()) log(device.name, device.transport);
///   rover.close();                                                     // or let it go out of scope
/// @endcode
///
/// ## Opening
/// Devices open one after the other, in the configuration's order:
///   1. the transport: the serial port (with its boot wait), the TCP connection, or the virtual board
///      (created, started, owned by the rover: it stops when the device closes);
///   2. the codec's client, made by its row of the codec table (codecs.hpp): `romi::Client`,
///      `proxy::Client` (primary or compat mode), `elcano::RingClient` (see "Elcano" below), or a
///      registered codec's own client;
///   3. proxy devices: the configured inits, in order (registered for replay after every device reset);
///      opening waits until they complete (primary: acked; compat: written) and, in primary mode, until
///      the session handshake is done, within `proxy::DeviceOptions::open_timeout`. A device that does not
///      answer fails the open (`DevicesError::device_not_ready`).
/// Virtual boards and rings open only in a program that links `Tether::virtual_uno` and called
/// `enable_virtual_boards()` (tether/devices/virtual_boards.hpp) first; otherwise their devices fail with a
/// `ConfigError` (`DevicesError::not_supported`) saying so, and a hardware-only service links no simulator.
/// Nothing is half-opened: when a device fails, the devices opened before it are closed (in reverse
/// order) before the error is reported. Errors are `ConfigError`s naming the JSON path of the culprit and
/// carrying the transport's or client's error_code:
///   `devices[1].transport.serial.path: /dev/ttyUSB9: No such file or directory`,
///   `devices[2].transport.tcp: rover-pi:4001: Connection refused`,
///   `devices[0].transport.virtual.firmware: /opt/fw/romi-test.elf: No such file or directory`,
///   `devices[1].options.inits[0]: servo 9: <the client's error>`.
/// `open_rover` blocks; like every blocking call of the transports and clients it needs another thread
/// running the executor. `async_open_rover` does not: a program whose only thread runs its `io_context`
/// (a service's event loop) opens its rover with it.
///
/// ## Elcano
/// An elcano device is the host's node in a ring (`elcano::RingClient`): over a serial port or TCP the
/// stream's TX goes to the first board and its RX comes from the last; a `virtual_ring` creates the boards
/// (`elcano-node` images, each EEPROM written before the first boot with the bytes the configuration gives
/// or the Elcano row encoded from a board's settings when it was parsed), wires them in
/// a lockstep group (first -> ... -> last -> host), starts it and waits until every board's UART receiver
/// is enabled. The rover owns the group; the ring stops when the device closes.
///
/// ## Handles and lifetime
/// The typed getters return shared pointers to the clients; they stay valid after the rover is gone, but
/// `close()` (and the rover's destruction) closes every client: later calls on a kept handle complete with
/// `operation_aborted`. A `Rover` is movable; one thread at a time may call `close()` or move it, while
/// the clients themselves are thread-safe.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/associated_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/execution/outstanding_work.hpp>
#include <boost/asio/prefer.hpp>

#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include "tether/client/link_clock.hpp"
#include "tether/devices/config.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/recording.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/unique_function.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::devices {

/// The client of an opened device: a shared pointer to its codec's client (`romi::Client`, `proxy::Client`,
/// `elcano::RingClient`, or a registered codec's own), reached by that type. Every codec, built in or
/// registered (codecs.hpp), hands out its client the same way:
///
/// @code
///   if (auto arm = device.client.get<romi::Client>()) arm->call("e");   // null for another codec's client
/// @endcode
///
/// A client type only needs a `close()` (idempotent, never waiting for the device): the rover calls it when
/// it closes.
class DeviceClient {
 public:
  /// No client.
  DeviceClient() = default;
  /// Holds `client` (null: no client).
  template <typename Client>
  DeviceClient(std::shared_ptr<Client> client)  // NOLINT: implicit: a codec's `open` returns its client
      : client_(client), type_(client ? &typeid(Client) : nullptr), close_(client ? &close_client<Client> : nullptr) {}

  /// The client if it is a `Client`, else null.
  template <typename Client>
  std::shared_ptr<Client> get() const {
    if (type_ == nullptr || *type_ != typeid(Client)) return nullptr;
    return std::static_pointer_cast<Client>(client_);
  }
  /// Closes the client (nothing when there is none).
  void close() const {
    if (close_ != nullptr) close_(client_.get());
  }
  /// True when a client is held.
  explicit operator bool() const { return client_ != nullptr; }

 private:
  template <typename Client>
  static void close_client(void* client) {
    static_cast<Client*>(client)->close();
  }

  std::shared_ptr<void> client_;
  const std::type_info* type_ = nullptr;
  void (*close_)(void*) = nullptr;
};

/// One opened device.
struct RoverDevice {
  std::string name;           ///< Its name in the configuration.
  Codec codec{};              ///< Its codec.
  std::string transport;      ///< `describe(transport)`: `serial /dev/ttyACM0 115200`, `virtual proxy.elf (...)`.
  DeviceClient client;        ///< The client (`romi::Client`, `proxy::Client`, `elcano::RingClient`).
  /// The simulated boards behind a virtual device (one, or a ring's in ring order); empty for hardware.
  /// For fault injection, resets and pin checks (`tether demo`); each keeps its board alive.
  std::vector<std::shared_ptr<transports::VirtualUno>> boards;
  /// What the client's deadlines run on: a virtual device's board time (`transports::VirtualUnoClock`,
  /// see "Clocks of virtual devices"); null for hardware (the steady clock). For a program's own
  /// deadlines that must agree with the client's.
  std::shared_ptr<client::LinkClock> clock;
  /// The serial port behind a serial device (null for the other transports): its link events
  /// (`add_link_handler`: down, up, gave up) and outage counters (`link_counters`) when it is supervised
  /// (`"reconnect"`, on by default).
  std::shared_ptr<transports::SerialPortStream> port;
  /// The recording of its link when it is recorded (`DeviceConfig::record` or `RoverConfig::record`), else
  /// null: its recorder's counters (`recorder()->counters()`: packets written, dropped, why it stopped).
  std::shared_ptr<transports::RecordingStream> recording = nullptr;
};

/// Hooks of `open_rover`.
struct OpenOptions {
  /// Called after each device opened (its inits done), on the opening thread, before the next one opens
  /// (logging, progress). An exception it throws fails the open: the devices opened so far are closed.
  std::function<void(const RoverDevice& device)> on_opened;
  /// Called with each device as soon as its client exists, before a proxy device's inits and handshake:
  /// attach event handlers and log sinks here to see everything the device says from the start. Same
  /// thread and exception rules as `on_opened`.
  std::function<void(const RoverDevice& device)> on_client;
  /// Called with each device's transport stream before its client is created; returns the stream the
  /// client uses (e.g. a `transports::FaultInjectingStream` around it, for noise and byte counts). The
  /// returned stream owns the one it was given. Unset: the stream is used as it is.
  std::function<std::shared_ptr<transports::ByteStream>(const DeviceConfig& device,
                                                        std::shared_ptr<transports::ByteStream> stream)>
      wrap_stream;
};

namespace detail {
class RoverOpener;  // builds a Rover device by device (rover.cpp)
}  // namespace detail

/// The opened devices of a rover. Movable, not copyable. See the file overview.
class Rover {
 public:
  /// A rover without devices (what a failed `open_rover(..., error)` returns).
  Rover();
  /// Closes every device (`close()`).
  ~Rover();
  /// Takes `other`'s devices; `other` is left empty.
  Rover(Rover&& other) noexcept;
  /// Closes this rover's devices and takes `other`'s.
  Rover& operator=(Rover&& other) noexcept;
  Rover(const Rover&) = delete;
  Rover& operator=(const Rover&) = delete;

  /// The client of device `name`, which must be a `Client` (`rover.client<romi::Client>("arm")`; a proxy
  /// or proxy-compat device's is a `proxy::Client`, an elcano device's an `elcano::RingClient`). Throws
  /// `std::out_of_range` when there is no such device (the message lists the devices) or its client is
  /// another type (the message says which codec it speaks and which have a `Client`).
  template <typename Client>
  std::shared_ptr<Client> client(std::string_view name) const {
    const RoverDevice& device = lookup(name);
    if (auto typed = device.client.get<Client>()) return typed;
    throw_other_client(device, typeid(Client));
  }
  /// The device `name`, or null.
  const RoverDevice* find(std::string_view name) const;
  /// Every device, in the configuration's order.
  const std::vector<RoverDevice>& devices() const;

  /// Closes every client (in reverse order), stops the virtual boards and rings and closes the capture files
  /// (what was recorded is on disk when it returns). Idempotent; the rover
  /// is empty afterwards. Never waits for a device (see the clients' `close()`).
  void close();
  /// True while the rover holds devices.
  bool is_open() const;

 private:
  friend class detail::RoverOpener;
  const RoverDevice& lookup(std::string_view name) const;
  [[noreturn]] static void throw_other_client(const RoverDevice& device, const std::type_info& wanted);

  std::vector<RoverDevice> devices_;
  std::vector<std::function<void()>> stops_;  // stop what the clients do not (virtual rings), after they closed
};

/// The if_description of `device`'s interface in a capture (docs/captures.md):
/// `tether codec=romi baud=115200 transport=serial`, then its codec row's `capture_words`.
std::string capture_description(const DeviceConfig& device);

/// Wraps `stream` so that `recorder` records it as `device`'s link: an interface named after the device,
/// described by `capture_description`, cut by its codec row's `capture_framing`.
std::shared_ptr<transports::RecordingStream> record_stream(const DeviceConfig& device,
                                                           std::shared_ptr<transports::ByteStream> stream,
                                                           std::shared_ptr<transports::CaptureRecorder> recorder);

/// A device's transport opened on its own, without a client (`tether monitor` reads the raw bytes).
struct OpenedTransport {
  /// The byte stream; it keeps alive what it needs (a virtual board, a virtual ring's boards).
  std::shared_ptr<transports::ByteStream> stream;
  /// The simulated boards behind it (see `RoverDevice::boards`); empty for hardware.
  std::vector<std::shared_ptr<transports::VirtualUno>> boards;
  /// Stops what closing the stream does not (a virtual ring's simulation thread); empty when nothing.
  std::function<void()> stop;
  /// The clock a client of this stream runs its deadlines on (see `RoverDevice::clock`): the board's
  /// simulated time for a virtual board or ring, null for hardware (the steady clock).
  std::shared_ptr<client::LinkClock> clock;
  /// The serial port, for a serial device (see `RoverDevice::port`); else null.
  std::shared_ptr<transports::SerialPortStream> port;
};

/// Opens only `device`'s transport, as `open_rover` does (serial port with its boot wait, TCP, a virtual
/// board, a virtual ring with its EEPROMs written before the first boot). Throws `ConfigError` with the
/// path `transport...`. Blocks; another thread must run `executor`.
OpenedTransport open_transport(const DeviceConfig& device, boost::asio::any_io_executor executor);

/// Opens every device of `config` (validated first). Throws `ConfigError`: its `path()` names the device's
/// configuration, its `code()` is the cause (the transport's error, `DevicesError::device_not_ready`, ...).
/// Blocks; another thread must run `executor`.
Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor,
                 const OpenOptions& options = OpenOptions());
/// Non-throwing `open_rover`: on failure returns an empty rover, sets `error` (the `ConfigError`'s code)
/// and, when given, `*message` (its `what()`).
Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, error_code& error,
                 std::string* message = nullptr);
/// Non-throwing `open_rover` with hooks.
Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, const OpenOptions& options,
                 error_code& error, std::string* message = nullptr);

/// Completion signature of `async_open_rover`: the `ConfigError` (or any other exception) as an
/// exception_ptr, or the rover. With `use_future` the future's `get()` rethrows it.
using OpenSignature = void(std::exception_ptr, Rover);

namespace detail {
/// Type-erased completion handler of `async_open_rover`.
using OpenHandler = transports::UniqueFunction<OpenSignature>;
/// Runs `open_rover` on a thread of its own and hands the outcome to `handler` (rover.cpp).
void start_open(RoverConfig config, boost::asio::any_io_executor executor, OpenOptions options, OpenHandler handler);
}  // namespace detail

/// Opens `config` without blocking the caller: the blocking `open_rover` runs on a short-lived thread of its
/// own (the executor's threads stay free to run the transports), then the handler runs on its associated
/// executor (default: `executor`) with `(exception_ptr, Rover)`. Any completion token: a callback,
/// `asio::use_future` (`get()` rethrows the ConfigError), `asio::use_awaitable`. `options.on_opened` runs on
/// the opening thread. The io_context must keep running until the handler has run.
template <typename OpenToken>
auto async_open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, const OpenOptions& options,
                      OpenToken&& token) {
  return boost::asio::async_initiate<OpenToken, OpenSignature>(
      [](auto handler, RoverConfig settings, boost::asio::any_io_executor target, OpenOptions hooks) {
        auto tracked = boost::asio::prefer(boost::asio::get_associated_executor(handler, target),
                                           boost::asio::execution::outstanding_work.tracked);
        detail::start_open(std::move(settings), std::move(target), std::move(hooks),
                           [handler = std::move(handler), tracked = std::move(tracked)](std::exception_ptr failure,
                                                                                         Rover rover) mutable {
                             boost::asio::dispatch(tracked, [handler = std::move(handler), failure,
                                                             rover = std::move(rover)]() mutable {
                               handler(failure, std::move(rover));
                             });
                           });
      },
      token, config, std::move(executor), options);
}

/// `async_open_rover` without hooks.
template <typename OpenToken>
auto async_open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, OpenToken&& token) {
  return async_open_rover(config, std::move(executor), OpenOptions(), std::forward<OpenToken>(token));
}

}  // namespace tether::devices
