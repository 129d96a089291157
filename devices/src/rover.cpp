// Opening a rover: transports, clients, proxy inits; rollback on failure; typed lookups.
#include "tether/devices/rover.hpp"

#include <cxxabi.h>

#include <cerrno>

#include <cstdlib>
#include <filesystem>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "builtin_codecs.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "virtual_board_opener.hpp"

namespace tether::devices {

namespace detail {

namespace {

// Set by enable_virtual_boards() (Tether::virtual_uno); null until then. Atomic: a program may enable them on
// one thread while another opens a rover of hardware.
constinit std::atomic<VirtualBoardOpener> virtual_board_opener{nullptr};

std::string device_path(std::size_t index) { return "devices[" + std::to_string(index) + "]"; }

[[noreturn]] void fail(std::string path, std::string detail, error_code code) {
  throw ConfigError(std::move(path), std::move(detail), code);
}

// --- transports ---------------------------------------------------------------------------------------------

std::shared_ptr<transports::SerialPortStream> open_serial(SerialTransport serial, Codec codec, const std::string& path,
                                                    const boost::asio::any_io_executor& executor) {
  // The codec's firmware says what its boot looks like, unless the program gave a signature of its own.
  if (!serial.options.boot_signature.usable()) serial.options.boot_signature = codec_row(codec).boot;
  error_code error;
  std::string message;
  const std::string port = transports::resolve_port(serial.port(), error, &message);
  if (error) fail(path + ".port", message, error);
  // Opened by its spec, not the path found: after an outage the board is looked up again by identity.
  auto opened = transports::SerialPortStream::async_open(executor, serial.port(), serial.options, boost::asio::use_future);
  std::shared_ptr<transports::SerialPortStream> stream = transports::get_or_error(opened, error);
  if (!error) return stream;
  if (error == transports::TransportError::boot_timeout) {
    fail(path + ".ready_banner",
         port + ": no " + nlohmann::json(serial.options.ready_banner).dump() + " banner within " +
             std::to_string(serial.options.boot_timeout.count()) + " ms",
         error);
  }
  if (error == transports::TransportError::invalid_option) fail(path + ".baud", port + ": " + error.message(), error);
  // The two a user can act on get named: the wrong file, and a port some other program holds (TIOCEXCL).
  std::string reason = error.message();
  const bool os = error.category() == boost::system::system_category();
  if (os && error.value() == ENOTTY) {
    reason = "not a serial port (" + reason + ")";
  } else if (os && error.value() == EBUSY) {
    reason = "held by another process (" + reason + ")";
  }
  fail(path + (serial.path.empty() ? ".port" : ".path"), port + ": " + reason, error);
}

std::shared_ptr<transports::ByteStream> open_tcp(const TcpTransport& tcp, const std::string& path,
                                                 const boost::asio::any_io_executor& executor) {
  error_code error;
  auto stream = transports::TcpStream::connect(executor, tcp.host, tcp.port, tcp.connect_timeout, error);
  if (!error) return stream;
  fail(path, tcp.host + ":" + std::to_string(tcp.port) + ": " + error.message(), error);
}

// --- one device's transport -----------------------------------------------------------------------------------

// Opens `device`'s transport; errors are ConfigErrors naming `transport_path` (devices[i].transport).
OpenedTransport open_device_transport(const DeviceConfig& device, const std::string& transport_path,
                                      const boost::asio::any_io_executor& executor) {
  OpenedTransport opened;
  try {
    if (const auto* serial = std::get_if<SerialTransport>(&device.transport)) {
      opened.port = open_serial(*serial, device.codec, transport_path + ".serial", executor);
      opened.stream = opened.port;
    } else if (const auto* tcp = std::get_if<TcpTransport>(&device.transport)) {
      opened.stream = open_tcp(*tcp, transport_path + ".tcp", executor);
    } else if (const VirtualBoardOpener opener = virtual_board_opener.load(std::memory_order_acquire)) {
      opened = opener(device, transport_path, executor);
    } else {
      fail(transport_path + (std::holds_alternative<VirtualTransport>(device.transport) ? ".virtual" : ".virtual_ring"),
           "virtual boards are not enabled in this program: call tether::devices::enable_virtual_boards() "
           "(tether/devices/virtual_boards.hpp) first, and link Tether::virtual_uno (CMake) or tether-virtual-uno "
           "(pkg-config), which runs the simulator",
           make_error_code(DevicesError::not_supported));
    }
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& error) {
    fail(transport_path, error.what(), make_error_code(DevicesError::invalid_config));
  }
  return opened;
}

}  // namespace

void register_virtual_board_opener(VirtualBoardOpener opener) noexcept {
  virtual_board_opener.store(opener, std::memory_order_release);
}

/// Opens devices into a Rover; closes what it opened when one fails.
class RoverOpener {
 public:
  static Rover open(const RoverConfig& config, const boost::asio::any_io_executor& executor,
                    const OpenOptions& options) {
    validate(config);
    Rover rover;
    Recorders recorders;
    try {
      // The capture files first: a file that may not be written fails the open before any device resets.
      for (std::size_t i = 0; i < config.devices.size(); ++i) {
        const DeviceConfig& device = config.devices[i];
        if (device.record) {
          recorders.for_device.push_back(recorder_of(rover, recorders, *device.record, device_path(i) + ".record"));
        } else if (config.record) {
          recorders.for_device.push_back(recorder_of(rover, recorders, *config.record, "record"));
        } else {
          recorders.for_device.push_back(nullptr);
        }
      }
      for (std::size_t i = 0; i < config.devices.size(); ++i) {
        open_device(rover, config.devices[i], i, executor, options, recorders.for_device[i]);
        if (options.on_opened) options.on_opened(rover.devices_.back());
      }
    } catch (...) {
      rover.close();
      // A capture that recorded nothing goes with the failed open: opening again must not find it.
      for (const auto& [file, recorder] : recorders.by_file) recorder->discard_if_empty();
      throw;
    }
    return rover;
  }

 private:
  struct Recorders {
    std::vector<std::pair<std::filesystem::path, std::shared_ptr<transports::CaptureRecorder>>> by_file;
    std::vector<std::shared_ptr<transports::CaptureRecorder>> for_device;
  };

  // The recorder of `record`'s file: one per file, however many devices name it; closed with the rover.
  static std::shared_ptr<transports::CaptureRecorder> recorder_of(Rover& rover, Recorders& recorders,
                                                                  const transports::RecordOptions& record,
                                                                  const std::string& path) {
    const auto file = record.file.lexically_normal();
    for (const auto& [each, recorder] : recorders.by_file) {
      if (each == file) return recorder;
    }
    error_code error;
    std::string message;
    auto recorder = transports::CaptureRecorder::open(record, error, message);
    if (!recorder) fail(path, message, error);
    recorders.by_file.emplace_back(file, recorder);
    rover.stops_.push_back([recorder] { recorder->close(); });
    return recorder;
  }

  static void open_device(Rover& rover, const DeviceConfig& device, std::size_t index,
                          const boost::asio::any_io_executor& executor, const OpenOptions& hooks,
                          const std::shared_ptr<transports::CaptureRecorder>& recorder) {
    const std::string path = device_path(index);
    const std::string transport_path = path + ".transport";
    OpenedTransport transport = open_device_transport(device, transport_path, executor);
    std::shared_ptr<transports::ByteStream> stream = std::move(transport.stream);
    std::function<void()> stop = std::move(transport.stop);  // what the client's close does not stop (a ring)
    std::vector<std::shared_ptr<transports::VirtualUno>> boards = std::move(transport.boards);
    try {
      if (hooks.wrap_stream) stream = hooks.wrap_stream(device, stream);
    } catch (const std::exception& error) {
      stream->close();
      if (stop) stop();
      fail(transport_path, std::string("wrap_stream: ") + error.what(), make_error_code(DevicesError::invalid_config));
    }
    // Outside the program's wrapper: what is recorded is what the client wrote and read.
    std::shared_ptr<transports::RecordingStream> recording;
    if (recorder) {
      recording = record_stream(device, stream, recorder);
      stream = recording;
    }

    RoverDevice opened;
    opened.name = device.name;
    opened.codec = device.codec;
    opened.transport = describe(device.transport);
    opened.boards = std::move(boards);
    opened.clock = transport.clock;
    opened.port = transport.port;
    opened.recording = recording;
    try {
      const CodecRow& codec = codec_row(device.codec);
      opened.client = codec.open(stream, device, std::move(transport.clock));
      // Registered before waiting: a failure below closes it with the others.
      rover.devices_.push_back(std::move(opened));
      if (stop) rover.stops_.push_back(std::move(stop));
      if (hooks.on_client) hooks.on_client(rover.devices_.back());
      if (codec.await_ready) codec.await_ready(rover.devices_.back().client, device, path);
    } catch (const ConfigError&) {
      stream->close();
      if (stop) stop();
      throw;
    } catch (const std::exception& error) {
      stream->close();
      if (stop) stop();
      fail(path + ".options", error.what(), make_error_code(DevicesError::invalid_config));
    }
  }
};

}  // namespace detail

// --- Rover ------------------------------------------------------------------------------------------------

Rover::Rover() = default;

Rover::~Rover() { close(); }

Rover::Rover(Rover&& other) noexcept : devices_(std::move(other.devices_)), stops_(std::move(other.stops_)) {
  other.devices_.clear();
  other.stops_.clear();
}

Rover& Rover::operator=(Rover&& other) noexcept {
  if (this != &other) {
    close();
    devices_ = std::move(other.devices_);
    stops_ = std::move(other.stops_);
    other.devices_.clear();
    other.stops_.clear();
  }
  return *this;
}

void Rover::close() {
  for (auto device = devices_.rbegin(); device != devices_.rend(); ++device) {
    device->client.close();
  }
  for (auto stop = stops_.rbegin(); stop != stops_.rend(); ++stop) (*stop)();
  devices_.clear();
  stops_.clear();
}

bool Rover::is_open() const { return !devices_.empty(); }

const std::vector<RoverDevice>& Rover::devices() const { return devices_; }

const RoverDevice* Rover::find(std::string_view name) const {
  for (const auto& device : devices_) {
    if (device.name == name) return &device;
  }
  return nullptr;
}

const RoverDevice& Rover::lookup(std::string_view name) const {
  const RoverDevice* device = find(name);
  if (device != nullptr) return *device;
  const std::string quoted_name = nlohmann::json(std::string(name)).dump();
  if (devices_.empty()) throw std::out_of_range("rover: no device " + quoted_name + " (the rover has no devices)");
  NameList names;
  for (const auto& each : devices_) names.add(each.name);
  throw std::out_of_range("rover: no device " + quoted_name + " (devices: " + names.text() + ")");
}

void Rover::throw_other_client(const RoverDevice& device, const std::type_info& wanted) {
  std::string codecs;
  for (const CodecRow* row : codec_rows()) {
    if (row->client_type == nullptr || *row->client_type != wanted) continue;
    codecs += (codecs.empty() ? "" : " or ") + std::string(row->name);
  }
  if (codecs.empty()) {
    // No row has that client: name the type as written (`tether::romi::Client`), not its mangled name.
    int status = 0;
    const std::unique_ptr<char, void (*)(void*)> readable(abi::__cxa_demangle(wanted.name(), nullptr, nullptr, &status),
                                                          std::free);
    codecs = std::string("a device with a ") + (status == 0 && readable ? readable.get() : wanted.name()) + " client";
  }
  throw std::out_of_range("rover: device " + nlohmann::json(device.name).dump() + " speaks " +
                          std::string(to_string(device.codec)) + ", not " + codecs);
}

// --- open_rover -------------------------------------------------------------------------------------------

Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, const OpenOptions& options) {
  return detail::RoverOpener::open(config, executor, options);
}

Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, const OpenOptions& options,
                 error_code& error, std::string* message) {
  error.clear();
  if (message != nullptr) message->clear();
  try {
    return detail::RoverOpener::open(config, executor, options);
  } catch (const ConfigError& failure) {
    error = failure.code();
    if (message != nullptr) *message = failure.what();
  }
  return Rover();
}

namespace detail {

void start_open(RoverConfig config, boost::asio::any_io_executor executor, OpenOptions options, OpenHandler handler) {
  std::thread([config = std::move(config), executor = std::move(executor), options = std::move(options),
               handler = std::move(handler)]() mutable {
    std::exception_ptr failure;
    Rover rover;
    try {
      rover = RoverOpener::open(config, executor, options);
    } catch (...) {
      failure = std::current_exception();
    }
    handler(failure, std::move(rover));
  }).detach();
}

}  // namespace detail

Rover open_rover(const RoverConfig& config, boost::asio::any_io_executor executor, error_code& error,
                 std::string* message) {
  return open_rover(config, std::move(executor), OpenOptions(), error, message);
}

std::string capture_description(const DeviceConfig& device) {
  using transports::capture_word_value;
  const CodecRow& row = codec_row(device.codec);
  std::string baud = "-";
  std::string transport;
  if (const auto* serial = std::get_if<SerialTransport>(&device.transport)) {
    baud = std::to_string(serial->options.baud);
    transport = "serial";
  } else if (std::holds_alternative<TcpTransport>(device.transport)) {
    transport = "tcp";
  } else if (std::holds_alternative<VirtualTransport>(device.transport)) {
    transport = "virtual";
  } else {
    transport = "virtual_ring";
  }
  std::string description = "tether codec=" + capture_word_value(row.name) + " baud=" + baud + " transport=" + transport;
  if (row.capture_words) {
    const std::string words = row.capture_words(device);
    if (!words.empty()) description += " " + words;
  }
  return description;
}

std::shared_ptr<transports::RecordingStream> record_stream(const DeviceConfig& device,
                                                           std::shared_ptr<transports::ByteStream> stream,
                                                           std::shared_ptr<transports::CaptureRecorder> recorder) {
  const CodecRow& row = codec_row(device.codec);
  const transports::CaptureFraming framing = row.capture_framing ? row.capture_framing(device) : nullptr;
  return transports::RecordingStream::wrap(std::move(stream), std::move(recorder), device.name,
                                           capture_description(device), framing);
}

OpenedTransport open_transport(const DeviceConfig& device, boost::asio::any_io_executor executor) {
  return detail::open_device_transport(device, "transport", executor);
}

}  // namespace tether::devices
