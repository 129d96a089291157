// Device selection shared by send, shell, monitor and stats (see device_options.hpp).
#include "device_options.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <random>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "message_text.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

#ifndef TETHER_FIRMWARE_DIR
#error "TETHER_FIRMWARE_DIR must name the build's firmware folder"
#endif

namespace tether::cli {

const char* const kDeviceUsage =
    "device (exactly one of):\n"
    "  --port PATH         a serial port, or a pty (the one `tether sim` prints); with:\n"
    "    --codec C         romi, proxy, proxy-compat or elcano (default: romi; proxy for send)\n"
    "    --baud N          line speed (default 115200; 57600 for proxy-compat)\n"
    "    --boot-wait MS    wait after opening and drop what the board printed meanwhile (default 0; 2000 for\n"
    "                      an Arduino Uno, which resets when the port opens)\n"
    "  --config FILE --device NAME\n"
    "                      device NAME of a rover configuration (JSON, docs/examples/); its transport, codec\n"
    "                      and options come from the file (bare firmware names resolve in the firmware folder)\n"
    "  --virtual FIRMWARE  starts a virtual Arduino Uno running FIRMWARE: a path to an .elf, or an image name\n"
    "                      (romi-test, proxy, proxy-compat, elcano-node) in the firmware folder\n"
    "                      ($TETHER_FIRMWARE_DIR, default: the build's). The codec follows the name\n"
    "                      (proxy-compat*, proxy*, elcano*, else romi) unless --codec says\n"
    "  elcano only, with --port or --virtual:\n"
    "    --generation B|D  the ring's wire generation (default B)\n"
    "    --capture TYPES   message types the host consumes: a comma-separated list of drive, sensor, goal,\n"
    "                      segment (default: none; everything else is forwarded round the ring)\n";

namespace {

std::optional<devices::Codec> parse_codec(std::string_view text) {
  if (text == "romi") return devices::Codec::romi;
  if (text == "proxy") return devices::Codec::proxy;
  if (text == "proxy-compat") return devices::Codec::proxy_compat;
  if (text == "elcano") return devices::Codec::elcano;
  return std::nullopt;
}

std::string codec_name(devices::Codec codec) { return std::string(devices::to_string(codec)); }

// The codec an image name suggests.
devices::Codec codec_of_image(const std::filesystem::path& firmware) {
  const std::string stem = firmware.stem().string();
  if (stem.starts_with("proxy-compat")) return devices::Codec::proxy_compat;
  if (stem.starts_with("proxy")) return devices::Codec::proxy;
  if (stem.starts_with("elcano")) return devices::Codec::elcano;
  return devices::Codec::romi;
}

std::filesystem::path resolve_firmware(const std::string& firmware) {
  if (firmware.find('/') != std::string::npos) return firmware;
  const bool has_suffix = firmware.size() > 4 && firmware.ends_with(".elf");
  return std::filesystem::path(firmware_dir()) / (has_suffix ? firmware : firmware + ".elf");
}

// Default options of `codec` for a device named on the command line.
devices::CodecOptions default_codec_options(devices::Codec codec, std::uint32_t baud, const DeviceOptions& options) {
  switch (codec) {
    case devices::Codec::romi:
      return devices::RomiOptions();
    case devices::Codec::proxy:
    case devices::Codec::proxy_compat: {
      devices::ProxyDeviceOptions proxy;
      proxy.client = codec == devices::Codec::proxy ? proxy::ProxyOptions::primary() : proxy::ProxyOptions::compat();
      proxy.client.timing.baud = baud;
      return proxy;
    }
    case devices::Codec::elcano: {
      devices::ElcanoOptions elcano_options;
      elcano_options.generation = options.generation.value_or(elcano::Generation::b);
      elcano_options.capture = options.capture.value_or(elcano::TypeSet());
      elcano_options.pacing.baud = baud;
      return elcano_options;
    }
  }
  return devices::RomiOptions();
}

// --- opening ----------------------------------------------------------------------------------------------

std::shared_ptr<transports::ByteStream> open_transport(const devices::TransportConfig& transport,
                                                       const boost::asio::any_io_executor& executor, Progress& progress,
                                                       std::string& message) {
  boost::system::error_code error;
  if (const auto* serial = std::get_if<devices::SerialTransport>(&transport)) {
    std::string text = "opening " + serial->path;
    if (serial->options.boot_wait.count() > 0) {
      text += " (boot wait " + std::to_string(serial->options.boot_wait.count()) + " ms)";
    }
    progress.show(text + "...");
    auto stream = transports::SerialPortStream::open(executor, serial->path, serial->options, error);
    if (!stream) message = "cannot open " + serial->path + ": " + error.message();
    return stream;
  }
  if (const auto* tcp = std::get_if<devices::TcpTransport>(&transport)) {
    const std::string where = tcp->host + ":" + std::to_string(tcp->port);
    progress.show("connecting to " + where + "...");
    auto stream = transports::TcpStream::connect(executor, tcp->host, tcp->port, tcp->connect_timeout, error);
    if (!stream) message = "cannot connect to " + where + ": " + error.message();
    return stream;
  }
  if (const auto* virt = std::get_if<devices::VirtualTransport>(&transport)) {
    progress.show("starting a virtual Uno with " + virt->board.firmware.string() + "...");
    auto stream = transports::VirtualUnoStream::open(executor, virt->board, error);
    if (!stream) {
      if (error == transports::TransportError::boot_timeout) {
        message = virt->board.firmware.string() + ": the firmware did not enable its UART receiver within " +
                  std::to_string(transports::VirtualUnoStream::kBootLimit.count()) + " ms";
      } else {
        message = "cannot start a virtual Uno with " + virt->board.firmware.string() + ": " + error.message();
      }
    }
    return stream;
  }
  message = "virtual rings are opened through the devices library only (not as a bare byte stream)";
  return nullptr;
}

// What opening a proxy device waits for.
struct ProxyReadiness {
  std::mutex mutex;
  std::condition_variable changed;
  bool established = false;
  std::size_t inits_pending = 0;
  std::optional<std::string> failure;
};

bool wait_for_proxy(proxy::ProxyClient& client, const devices::ProxyDeviceOptions& options,
                    const std::shared_ptr<ProxyReadiness>& ready, Progress& progress, std::string& message) {
  const bool primary = options.client.mode == proxy::Mode::primary;
  {
    const std::lock_guard lock(ready->mutex);
    ready->inits_pending = options.inits.size();
  }
  for (const devices::PinInit& init : options.inits) {
    const std::string what =
        std::string(init.kind == devices::PinInit::Kind::servo ? "servo " : "digital ") + std::to_string(init.pin);
    auto done = [ready, what](proxy::error_code error, proxy::SendResult) {
      const std::lock_guard lock(ready->mutex);
      --ready->inits_pending;
      if (error && !ready->failure) ready->failure = "init of " + what + ": " + error.message();
      ready->changed.notify_all();
    };
    if (init.kind == devices::PinInit::Kind::servo) {
      client.servo(init.pin).async_init(init.safe_value, done);
    } else {
      client.digital(init.pin).async_init(init.safe_value != 0, done);
    }
  }
  progress.show(primary ? "waiting for the proxy session (Reset, ResetEvent, inits)..." : "sending the inits...");
  std::unique_lock lock(ready->mutex);
  const bool finished = ready->changed.wait_for(lock, options.open_timeout, [&] {
    return ready->failure || (ready->inits_pending == 0 && (!primary || ready->established));
  });
  if (ready->failure) {
    message = *ready->failure;
    return false;
  }
  if (!finished) {
    message = primary ? "the device did not complete the session handshake within " +
                            std::to_string(options.open_timeout.count()) + " ms (is it a proxy device?)"
                      : "the inits were not written within " + std::to_string(options.open_timeout.count()) + " ms";
    return false;
  }
  return true;
}

}  // namespace

std::string firmware_dir() {
  if (const char* dir = std::getenv("TETHER_FIRMWARE_DIR"); dir != nullptr && *dir != '\0') return dir;
  return TETHER_FIRMWARE_DIR;
}

namespace {

enum class OptionParse { not_mine, consumed, error };

// Looks at argv[index]: a device option (and its value, `index` advanced past it) is stored in `options`;
// `error` gets the message of a bad value.
OptionParse parse_device_option(int argc, char** argv, int& index, DeviceOptions& options, std::string& error) {
  const std::string_view argument = argv[index];
  static constexpr std::string_view kWithValue[] = {"--port",   "--baud",    "--codec",      "--boot-wait", "--config",
                                                    "--device", "--virtual", "--generation", "--capture"};
  if (std::find(std::begin(kWithValue), std::end(kWithValue), argument) == std::end(kWithValue)) {
    return OptionParse::not_mine;
  }
  if (index + 1 >= argc) {
    error = std::string(argument) + " needs a value";
    return OptionParse::error;
  }
  const std::string_view value = argv[++index];
  auto bad = [&](const std::string& expected) {
    error = std::string(argument) + " needs " + expected + ", got '" + std::string(value) + "'";
    return OptionParse::error;
  };
  if (argument == "--port") {
    if (value.empty()) return bad("a path");
    options.port = value;
  } else if (argument == "--baud") {
    options.baud = parse_number(value, 1, 4000000);
    if (!options.baud) return bad("a positive number");
  } else if (argument == "--codec") {
    options.codec = parse_codec(value);
    if (!options.codec) return bad("romi, proxy, proxy-compat or elcano");
  } else if (argument == "--boot-wait") {
    options.boot_wait_ms = parse_number(value, 0, 60000);
    if (!options.boot_wait_ms) return bad("milliseconds (0..60000)");
  } else if (argument == "--config") {
    if (value.empty()) return bad("a file");
    options.config_file = value;
  } else if (argument == "--device") {
    if (value.empty()) return bad("a device name");
    options.device = value;
  } else if (argument == "--virtual") {
    if (value.empty()) return bad("a firmware image");
    options.firmware = value;
  } else if (argument == "--generation") {
    if (value == "B" || value == "b") {
      options.generation = elcano::Generation::b;
    } else if (value == "D" || value == "d") {
      options.generation = elcano::Generation::d;
    } else {
      return bad("B or D");
    }
  } else {
    options.capture = parse_elcano_types(value);
    if (!options.capture) return bad("message types (drive,sensor,goal,segment)");
  }
  return OptionParse::consumed;
}

}  // namespace

std::optional<int> parse_device_arguments(int argc, char** argv, const CommandText& text, DeviceOptions& options,
                                          const ArgumentHandler& handle) {
  return parse_arguments(argc, argv, text, [&](std::string_view argument, int& index) -> std::optional<int> {
    std::string error;
    switch (parse_device_option(argc, argv, index, options, error)) {
      case OptionParse::consumed:
        return std::nullopt;
      case OptionParse::error:
        return text.usage_error(error);
      case OptionParse::not_mine:
        break;
    }
    return handle(argument, index);
  });
}

std::optional<DeviceTarget> resolve_device(const DeviceOptions& options, devices::Codec default_codec,
                                           std::string& error) {
  const bool port = !options.port.empty();
  const bool config = !options.config_file.empty() || !options.device.empty();
  const bool board = !options.firmware.empty();
  if (port + config + board > 1) {
    error = "give only one of --port, --config/--device and --virtual";
    return std::nullopt;
  }
  if (!port && !config && !board) {
    error = "no device given: use --port PATH, --config FILE --device NAME, or --virtual FIRMWARE";
    return std::nullopt;
  }
  DeviceTarget target;
  if (config) {
    for (const auto& [given, name] :
         {std::pair{options.codec.has_value(), "--codec"}, std::pair{options.baud.has_value(), "--baud"},
          std::pair{options.boot_wait_ms.has_value(), "--boot-wait"},
          std::pair{options.generation.has_value(), "--generation"},
          std::pair{options.capture.has_value(), "--capture"}}) {
      if (given) {
        error = std::string(name) + " does not apply with --config (the configuration sets it)";
        return std::nullopt;
      }
    }
    if (options.config_file.empty()) {
      error = "--device needs --config FILE";
      return std::nullopt;
    }
    devices::RoverConfig rover;
    try {
      devices::ParseOptions where;
      where.firmware_dir = firmware_dir();
      rover = devices::load_config(options.config_file, where);
    } catch (const devices::ConfigError& failure) {
      error = failure.what();
      return std::nullopt;
    }
    std::string names;
    for (std::size_t i = 0; i < rover.devices.size(); ++i) {
      const devices::DeviceConfig& device = rover.devices[i];
      if (device.name == options.device) {
        target.config = device;
        target.label = device.name + " in " + options.config_file + " (devices[" + std::to_string(i) + "], " +
                       devices::describe(device.transport) + ", " + codec_name(device.codec) + ")";
        return target;
      }
      names += (names.empty() ? "" : ", ") + device.name;
    }
    error = options.device.empty()
                ? "--config needs --device NAME (devices in " + options.config_file + ": " + names + ")"
                : "no device '" + options.device + "' in " + options.config_file + " (devices: " + names + ")";
    return std::nullopt;
  }

  if (board) {
    if (options.baud) {
      error = "--baud does not apply to --virtual (a virtual board has no line speed to set)";
      return std::nullopt;
    }
    if (options.boot_wait_ms) {
      error = "--boot-wait does not apply to --virtual (the board is ready when it opens)";
      return std::nullopt;
    }
  }
  const std::filesystem::path firmware = board ? resolve_firmware(options.firmware) : std::filesystem::path();
  const devices::Codec codec = options.codec ? *options.codec : (board ? codec_of_image(firmware) : default_codec);
  if (codec != devices::Codec::elcano && (options.generation || options.capture)) {
    error = std::string(options.generation ? "--generation" : "--capture") + " applies to the elcano codec only";
    return std::nullopt;
  }
  const std::uint32_t baud = options.baud.value_or(codec == devices::Codec::proxy_compat ? 57600 : 115200);
  target.config.codec = codec;
  target.config.options = default_codec_options(codec, baud, options);
  if (port) {
    devices::SerialTransport serial;
    serial.path = options.port;
    serial.options = transports::SerialOptions();
    serial.options.baud = baud;
    serial.options.boot_wait = std::chrono::milliseconds(options.boot_wait_ms.value_or(0));
    target.config.name = options.port;
    target.config.transport = serial;
  } else {
    devices::VirtualTransport virt;
    virt.board.firmware = firmware;
    virt.board.pacing = transports::Pacing::real_time;
    virt.board.name = firmware.stem().string();
    target.config.name = virt.board.name;
    target.config.transport = virt;
  }
  target.label = devices::describe(target.config.transport) + " (" + codec_name(codec) + ")";
  return target;
}

nlohmann::ordered_json link_counters_json(const LinkCounters& counters) {
  return {{"frames_ok", counters.frames_ok},
          {"crc_errors", counters.crc_errors},
          {"framing_errors", counters.framing_errors},
          {"oversize_frames", counters.oversize_frames},
          {"resyncs", counters.resyncs},
          {"partial_timeouts", counters.partial_timeouts},
          {"stale", counters.stale},
          {"duplicates", counters.duplicates},
          {"retries", counters.retries},
          {"timeouts", counters.timeouts},
          {"resets", counters.resets},
          {"failsafes", counters.failsafes}};
}

nlohmann::ordered_json OpenDevice::counters() const {
  nlohmann::ordered_json report;
  if (romi_) {
    report["link"] = link_counters_json(romi_->counters());
  } else if (proxy_) {
    const proxy::ProxyCounters counters = proxy_->counters();
    report["link"] = link_counters_json(counters.link);
    report["proxy"] = {{"messages_sent", counters.messages_sent}, {"acks", counters.acks},
                       {"pings_sent", counters.pings_sent},       {"ping_acks", counters.ping_acks},
                       {"resets_sent", counters.resets_sent},     {"inits_replayed", counters.inits_replayed},
                       {"undecodable", counters.undecodable},     {"unknown_messages", counters.unknown_messages},
                       {"pins_lost", counters.pins_lost}};
    const proxy::SessionStatus session = proxy_->session();
    report["session"] = {{"established", session.established}, {"session_id", nullptr}};
    if (session.session_id) report["session"]["session_id"] = *session.session_id;
  } else if (ring_) {
    const elcano::RingClientCounters counters = ring_->counters();
    report["link"] = link_counters_json(counters.link);
    report["ring"] = {{"captured", counters.ring.captured},
                      {"forwarded", counters.ring.forwarded},
                      {"originated", counters.ring.originated},
                      {"undeliverable", counters.ring.undeliverable},
                      {"queue_full_drops", counters.ring.queue_full_drops},
                      {"origins_expired", counters.ring.origins_expired},
                      {"origins_evicted", counters.ring.origins_evicted},
                      {"replies", counters.replies},
                      {"receive_overflows", counters.receive_overflows},
                      {"bytes_written", counters.bytes_written}};
  }
  return report;
}

nlohmann::ordered_json stats_report(const OpenDevice& device, double seconds, const nlohmann::ordered_json& extra) {
  nlohmann::ordered_json report = {{"device", device.description()},
                                   {"codec", codec_name(device.codec())},
                                   {"seconds", std::round(seconds * 1000.0) / 1000.0}};
  const nlohmann::ordered_json counters = device.counters();
  for (const auto& [key, value] : counters.items()) report[key] = value;
  for (const auto& [key, value] : extra.items()) report[key] = value;
  return report;
}

void OpenDevice::close() {
  if (romi_) romi_->close();
  if (proxy_) proxy_->close();
  if (ring_) ring_->close();
  if (rover_) rover_->close();
}

std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                      const ClientHooks& hooks, Progress& progress, std::string& error) {
  // The progress line goes away however opening ends (the caller prints the error or the first output).
  struct ClearProgress {
    Progress& progress;
    ~ClearProgress() { progress.clear(); }
  } clear_progress{progress};
  OpenDevice opened;
  opened.codec_ = target.config.codec;
  opened.description_ = target.label;

  if (std::holds_alternative<devices::VirtualRingTransport>(target.config.transport)) {
    // A ring of virtual boards (EEPROMs, wiring) is the devices library's to build.
    devices::RoverConfig rover_config;
    rover_config.devices.push_back(target.config);
    progress.show("starting " + devices::describe(target.config.transport) + "...");
    boost::system::error_code code;
    auto rover = std::make_shared<devices::Rover>(devices::open_rover(rover_config, executor, code, &error));
    if (code) return std::nullopt;
    for (const devices::RoverDevice& device : rover->devices()) {
      std::visit(
          [&](const auto& client) {
            using Client = std::decay_t<decltype(client)>;
            if constexpr (std::is_same_v<Client, std::shared_ptr<romi::RomiClient>>) {
              opened.romi_ = client;
            } else if constexpr (std::is_same_v<Client, std::shared_ptr<proxy::ProxyClient>>) {
              opened.proxy_ = client;
            } else if constexpr (std::is_same_v<Client, std::shared_ptr<elcano::RingClient>>) {
              opened.ring_ = client;
            }
          },
          device.client);
    }
    if (!opened.romi_ && !opened.proxy_ && !opened.ring_) {
      error = "the devices library opened " + target.config.name + " with a client this command does not know";
      return std::nullopt;
    }
    if (opened.romi_ && hooks.romi_log) opened.romi_->set_log_handler(hooks.romi_log);
    if (opened.proxy_ && hooks.proxy_events) opened.proxy_->add_event_handler(hooks.proxy_events);
    if (opened.ring_ && hooks.ring_events) opened.ring_->add_event_handler(hooks.ring_events);
    opened.rover_ = std::move(rover);
    return opened;
  }

  auto stream = open_transport(target.config.transport, executor, progress, error);
  if (!stream) return std::nullopt;
  try {
    switch (target.config.codec) {
      case devices::Codec::romi: {
        romi::ClientOptions options;
        options.timing = std::get<devices::RomiOptions>(target.config.options).timing;
        // Each run is a new host session: a random first id, never 255 (see call.cpp).
        const auto first_id = static_cast<std::uint8_t>(std::random_device()() % 255);
        options.last_id = static_cast<std::uint8_t>(first_id - 1);
        opened.romi_ = std::make_shared<romi::RomiClient>(stream, options);
        if (hooks.romi_log) opened.romi_->set_log_handler(hooks.romi_log);
        break;
      }
      case devices::Codec::proxy:
      case devices::Codec::proxy_compat: {
        const auto& options = std::get<devices::ProxyDeviceOptions>(target.config.options);
        auto ready = std::make_shared<ProxyReadiness>();
        proxy::EventHandler forward = hooks.proxy_events;
        auto handler = [ready, forward](const proxy::ProxyEvent& event) {
          if (std::holds_alternative<proxy::events::SessionEstablished>(event)) {
            const std::lock_guard lock(ready->mutex);
            ready->established = true;
            ready->changed.notify_all();
          } else if (const auto* failed = std::get_if<proxy::events::LinkFailed>(&event)) {
            const std::lock_guard lock(ready->mutex);
            if (!ready->failure) ready->failure = "the link failed: " + failed->error.message();
            ready->changed.notify_all();
          }
          if (forward) forward(event);
        };
        opened.proxy_ = std::make_shared<proxy::ProxyClient>(stream, options.client, handler);
        if (!wait_for_proxy(*opened.proxy_, options, ready, progress, error)) {
          opened.proxy_->close();
          return std::nullopt;
        }
        break;
      }
      case devices::Codec::elcano: {
        const auto& options = std::get<devices::ElcanoOptions>(target.config.options);
        elcano::RingClientOptions ring_options;
        ring_options.node.generation = options.generation;
        ring_options.node.capture = options.capture;
        ring_options.node.pacing = options.pacing;
        ring_options.timing = options.timing;
        opened.ring_ = std::make_shared<elcano::RingClient>(stream, ring_options, hooks.ring_events);
        break;
      }
    }
  } catch (const std::exception& failure) {
    stream->close();
    error = failure.what();
    return std::nullopt;
  }
  return opened;
}

std::shared_ptr<transports::ByteStream> open_stream(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                                    Progress& progress, std::string& error) {
  if (std::holds_alternative<devices::VirtualRingTransport>(target.config.transport)) {
    error =
        "a virtual ring cannot be opened as a bare byte stream (the devices library builds rings for its "
        "clients only); monitor a ring on its serial port";
    return nullptr;
  }
  auto stream = open_transport(target.config.transport, executor, progress, error);
  progress.clear();  // also after a failure: the caller prints the error next
  return stream;
}

std::string counters_table(const nlohmann::ordered_json& report) {
  std::size_t width = 0;
  for (const auto& [key, value] : report.items()) {
    width = std::max(width, key.size());
    if (value.is_object()) {
      for (const auto& [inner, unused] : value.items()) width = std::max(width, inner.size() + 2);
    }
  }
  auto text_of = [](const nlohmann::ordered_json& value) {
    if (value.is_string()) return value.get<std::string>();
    if (value.is_null()) return std::string("-");
    return dump(value);
  };
  std::string table;
  auto row = [&](const std::string& key, const std::string& value) {
    table += key;
    table.append(width + 2 - key.size(), ' ');
    table += value;
    table += '\n';
  };
  for (const auto& [key, value] : report.items()) {
    if (value.is_object()) {
      table += key + '\n';
      for (const auto& [inner, inner_value] : value.items()) row("  " + inner, text_of(inner_value));
    } else {
      row(key, text_of(value));
    }
  }
  return table;
}

}  // namespace tether::cli
