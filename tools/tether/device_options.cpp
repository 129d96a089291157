// Device selection shared by call, send, shell, monitor and stats (see device_options.hpp).
#include "device_options.hpp"

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "message_text.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

#if !defined(TETHER_FIRMWARE_DIR) || !defined(TETHER_INSTALLED_FIRMWARE_DIR)
#error "TETHER_FIRMWARE_DIR must name the build's firmware folder, TETHER_INSTALLED_FIRMWARE_DIR the installed one"
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
    "                      ($TETHER_FIRMWARE_DIR, default: the installed images, else the build's).\n"
    "                      The codec follows the name (proxy-compat*, proxy*, elcano*, else romi)\n"
    "                      unless --codec says\n"
    "  elcano only, with --port or --virtual:\n"
    "    --generation B|D  the ring's wire generation (default B)\n"
    "    --capture TYPES   message types the host consumes: a comma-separated list of drive, sensor, goal,\n"
    "                      segment (default: none; everything else is forwarded round the ring)\n"
    "  --virtual with an elcano image is a ring of one board that captures drive messages and answers each\n"
    "  with a sensor report S{s}{a}{b 0}{p 0,0}, which the host captures (default --capture sensor).\n";

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

// Default options of `codec` for a device named on the command line.
devices::CodecOptions default_codec_options(devices::Codec codec, std::uint32_t baud, const DeviceOptions& options) {
  switch (codec) {
    case devices::Codec::romi:
      return devices::RomiOptions();
    case devices::Codec::proxy:
    case devices::Codec::proxy_compat: {
      devices::ProxyDeviceOptions proxy;
      proxy.client = codec == devices::Codec::proxy ? proxy::Options::primary() : proxy::Options::compat();
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

}  // namespace

std::string firmware_dir() {
  if (const char* dir = std::getenv("TETHER_FIRMWARE_DIR"); dir != nullptr && *dir != '\0') return dir;
  // An installed or unpacked `tether` uses the images installed with it (relative to the binary, so a
  // prefix works wherever it is); the build tree's binary has none beside it and uses the build's.
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto installed = (self.parent_path() / TETHER_INSTALLED_FIRMWARE_DIR).lexically_normal();
    if (std::filesystem::is_directory(installed, error)) return installed.string();
  }
  return TETHER_FIRMWARE_DIR;
}

std::filesystem::path firmware_image(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const bool has_suffix = name.size() > 4 && name.ends_with(".elf");
  return std::filesystem::path(firmware_dir()) / (has_suffix ? name : name + ".elf");
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
    devices::NameList names;
    for (std::size_t i = 0; i < rover.devices.size(); ++i) {
      const devices::DeviceConfig& device = rover.devices[i];
      if (device.name == options.device) {
        target.config = device;
        target.label = device.name + " in " + options.config_file + " (devices[" + std::to_string(i) + "], " +
                       devices::describe(device.transport) + ", " + codec_name(device.codec) + ")";
        return target;
      }
      names.add(device.name);
    }
    error = options.device.empty()
                ? "--config needs --device NAME (devices in " + options.config_file + ": " + names.text() + ")"
                : "no device '" + options.device + "' in " + options.config_file + " (devices: " + names.text() + ")";
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
  const std::filesystem::path firmware = board ? firmware_image(options.firmware) : std::filesystem::path();
  if (board) {
    // Before the codec, which the image's name suggests: a missing image is "not found", not a codec mismatch.
    std::error_code status_error;
    const std::filesystem::file_status status = std::filesystem::status(firmware, status_error);
    if (!std::filesystem::is_regular_file(status)) {
      const int reason = std::filesystem::is_directory(status) ? EISDIR : ENOENT;
      error = "firmware image not found: " + firmware.string() + ": " + std::system_category().message(reason);
      return std::nullopt;
    }
  }
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
  } else if (codec == devices::Codec::elcano) {
    // The host and one board make a ring of one (host TX -> board -> host RX). An unconfigured board
    // captures nothing, so everything would come back undelivered: the board drives the servos from drive
    // messages and answers each with a sensor report (`kLoneVirtualNodeBehaviour`).
    devices::VirtualRingTransport ring;
    devices::RingBoardConfig node;
    node.firmware = firmware;
    devices::RingNodeSettings settings;
    settings.capture = elcano::TypeSet::of(elcano::Type::drive);
    settings.behaviour_bits = kLoneVirtualNodeBehaviour;
    node.eeprom = settings;
    // ... which the host captures (unless --capture says otherwise).
    if (!options.capture) {
      std::get<devices::ElcanoOptions>(target.config.options).capture = elcano::TypeSet::of(elcano::Type::sensor);
    }
    ring.boards.push_back(node);
    ring.pacing = transports::Pacing::real_time;
    target.config.name = firmware.stem().string();
    target.config.transport = ring;
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
    report["link"] = link_counters_json(romi_->counters().link);
  } else if (proxy_) {
    const proxy::Counters counters = proxy_->counters();
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
    const elcano::Counters counters = ring_->counters();
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

  // The devices library opens it as a rover service would (boot wait, random first Romi id, proxy inits and
  // handshake, rings); the hooks are attached as soon as the client exists, so no event is missed.
  devices::RoverConfig rover_config;
  rover_config.devices.push_back(target.config);
  devices::OpenOptions open_options;
  open_options.on_client = [&](const devices::RoverDevice& device) {
    std::visit(
        [&](const auto& client) {
          using Client = std::decay_t<decltype(client)>;
          if constexpr (std::is_same_v<Client, std::shared_ptr<romi::Client>>) {
            opened.romi_ = client;
            if (hooks.romi_events) client->on_event(hooks.romi_events);
          } else if constexpr (std::is_same_v<Client, std::shared_ptr<proxy::Client>>) {
            opened.proxy_ = client;
            if (hooks.proxy_events) client->on_event(hooks.proxy_events);
          } else {
            opened.ring_ = client;
            if (hooks.ring_events) client->on_event(hooks.ring_events);
          }
        },
        device.client);
    const bool proxy = device.codec == devices::Codec::proxy || device.codec == devices::Codec::proxy_compat;
    if (proxy) progress.show("waiting for the proxy session and inits...");
  };
  progress.show("opening " + devices::describe(target.config.transport) + "...");
  try {
    opened.rover_ = std::make_shared<devices::Rover>(devices::open_rover(rover_config, executor, open_options));
  } catch (const devices::ConfigError& failure) {
    error = failure.detail();  // the JSON path of a one-device rover would only confuse (--port, --virtual)
    return std::nullopt;
  }
  return opened;
}

std::shared_ptr<transports::ByteStream> open_stream(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                                    Progress& progress, std::string& error) {
  progress.show("opening " + devices::describe(target.config.transport) + "...");
  std::shared_ptr<transports::ByteStream> stream;
  try {
    // A ring's boards live as long as its stream.
    stream = devices::open_transport(target.config, std::move(executor)).stream;
  } catch (const devices::ConfigError& failure) {
    error = failure.detail();
  }
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
