// Device selection shared by call, send, shell, monitor and stats (see device_options.hpp).
#include "device_options.hpp"

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string_view>
#include <system_error>
#include <thread>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

#if !defined(TETHER_FIRMWARE_DIR) || !defined(TETHER_INSTALLED_FIRMWARE_DIR)
#error "TETHER_FIRMWARE_DIR must name the build's firmware folder, TETHER_INSTALLED_FIRMWARE_DIR the installed one"
#endif

namespace tether::cli {

namespace {

// The codecs' texts in the device usage, from their rows: the line speeds other than 115200
// (`; 57600 for proxy-compat`), the example images (`romi-test, proxy, ...`) and the image prefixes, longest
// first as they are matched (`proxy-compat*, elcano*, ...`).
struct RowTexts {
  std::string bauds;
  std::string images;
  std::string prefixes;
};

RowTexts row_texts() {
  RowTexts texts;
  std::vector<std::string_view> prefixes;
  const devices::Codec fallback = default_codec();
  for (const devices::CodecRow* row : devices::codec_rows()) {
    if (row->default_baud != 115200) {
      texts.bauds += "; " + std::to_string(row->default_baud) + " for " + std::string(row->name);
    }
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr) continue;
    if (!commands->example_image.empty()) {
      texts.images += (texts.images.empty() ? "" : ", ") + std::string(commands->example_image);
    }
    if (row->codec == fallback) continue;
    for (const std::string_view prefix : commands->image_prefixes) prefixes.push_back(prefix);
  }
  std::stable_sort(prefixes.begin(), prefixes.end(),
                   [](std::string_view a, std::string_view b) { return a.size() > b.size(); });
  for (const std::string_view prefix : prefixes) texts.prefixes += std::string(prefix) + "*, ";
  texts.prefixes += "else " + std::string(devices::to_string(fallback));
  return texts;
}

// The first codec row that takes the flag `name`, or null.
const CodecFlag* find_codec_flag(std::string_view name) {
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr) continue;
    for (const CodecFlag& flag : commands->flags) {
      if (flag.name == name) return &flag;
    }
  }
  return nullptr;
}

}  // namespace

std::string device_usage(std::string_view port_codec) {
  const RowTexts texts = row_texts();
  const std::string port_default =
      port_codec.empty() ? std::string(devices::to_string(default_codec())) : std::string(port_codec);
  std::string usage =
      "device (exactly one of):\n"
      "  --port PATH         a serial port, or a pty (the one `tether sim` prints); with:\n"
      "    --codec C         " + codec_choices() + " (default: " + port_default + ")\n"
      "    --baud N          line speed (default 115200" + texts.bauds + ")\n"
      "    --boot-wait MS    wait for the board after opening, at most MS (default 0: no wait; 2000 for an\n"
      "                      Arduino Uno, which resets when the port opens)\n"
      "    --boot MODE       how: detect (default where the codec knows its firmware's boot: ready when it\n"
      "                      announces itself or answers a probe, MS the upper bound), fixed (wait MS, drop\n"
      "                      what it printed), none\n"
      "  --config FILE --device NAME\n"
      "                      device NAME of a rover configuration (JSON, docs/examples/); its transport, codec\n"
      "                      and options come from the file (bare firmware names resolve in the firmware folder)\n"
      "  --virtual FIRMWARE  starts a virtual Arduino Uno running FIRMWARE: a path to an .elf, or an image name\n"
      "                      (" + texts.images + ") in the firmware folder\n"
      "                      ($TETHER_FIRMWARE_DIR, default: the installed images, else the build's).\n"
      "                      The codec follows the name (" + texts.prefixes + ")\n"
      "                      unless --codec says\n"
      "  --no-reconnect      a serial port that vanishes (unplugged) ends the link; by default the command\n"
      "                      waits for it to come back (its calls fail `disconnected` meanwhile) and goes on\n" +
      record_usage();
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr || (commands->flags.empty() && commands->usage_note.empty())) continue;
    if (!commands->flags.empty()) usage += "  " + std::string(row->name) + " only, with --port or --virtual:\n";
    for (const CodecFlag& flag : commands->flags) usage += flag.usage;
    usage += commands->usage_note;
  }
  return usage;
}



std::optional<devices::RoverConfig> rover_to_run(const std::string& config_file,
                                                 const std::filesystem::path& firmware_dir,
                                                 const transports::RecordOptions& record) {
  devices::ParseOptions parse;
  parse.firmware_dir = firmware_dir;
  std::optional<devices::RoverConfig> config;
  if (!config_file.empty()) config = devices::load_config(config_file, parse);
  if (!record.file.empty()) {
    if (!config) config = devices::parse_config(devices::default_virtual_rover_config(), parse);
    config->record = record;
    for (devices::DeviceConfig& device : config->devices) device.record.reset();
  }
  return config;
}

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

std::optional<std::string> firmware_image_problem(const std::filesystem::path& firmware) {
  std::error_code status_error;
  const std::filesystem::file_status status = std::filesystem::status(firmware, status_error);
  if (!std::filesystem::exists(status) || std::filesystem::is_directory(status)) {
    const int reason = std::filesystem::is_directory(status) ? EISDIR : ENOENT;
    return "firmware image not found: " + firmware.string() + ": " + std::system_category().message(reason);
  }
  if (std::filesystem::is_regular_file(status)) return std::nullopt;
  // A device, FIFO or socket exists, so "not found" would mislead; reading one could block or never end.
  const std::filesystem::file_type type = status.type();
  const char* kind = type == std::filesystem::file_type::character ? "a character device"
                     : type == std::filesystem::file_type::block   ? "a block device"
                     : type == std::filesystem::file_type::fifo    ? "a FIFO"
                     : type == std::filesystem::file_type::socket  ? "a socket"
                                                                   : "not a regular file";
  return "not a firmware image: " + firmware.string() + " is " + kind + " (an AVR ELF file is needed)";
}

std::filesystem::path firmware_image(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const bool has_suffix = name.size() > 4 && name.ends_with(".elf");
  return std::filesystem::path(firmware_dir()) / (has_suffix ? name : name + ".elf");
}

std::string record_usage(std::string_view write_flag) {
  const std::string flag = std::string(write_flag) + " FILE";
  return "recording (docs/captures.md):\n"
         "  " + flag + std::string(flag.size() < 18 ? 18 - flag.size() : 1, ' ') +
         "record what crosses the link into FILE (pcapng: Wireshark, tshark, `tether replay`);\n"
         "                      an existing FILE is an error unless --force\n"
         "    --force           overwrite FILE (and its ring files)\n"
         "    --record-max-bytes N    start the next ring file at N bytes (at least 4096)\n"
         "    --record-max-seconds S  start the next ring file after S seconds\n"
         "    --record-files N        ring files kept with a limit (2..1000, default 2): FILE, STEM.1.EXT, ...\n";
}

std::optional<transports::RecordOptions> record_options(const DeviceOptions& options, std::string& error) {
  if (options.record.empty()) {
    if (options.force) error = "--force applies to --record only";
    if (options.record_max_bytes) error = "--record-max-bytes needs --record FILE";
    if (options.record_max_seconds) error = "--record-max-seconds needs --record FILE";
    if (options.record_files) error = "--record-files needs --record FILE";
    return std::nullopt;
  }
  transports::RecordOptions record;
  record.file = options.record;
  record.overwrite = options.force;
  if (options.record_max_bytes) record.max_file_bytes = *options.record_max_bytes;
  if (options.record_max_seconds) record.max_file_duration = std::chrono::seconds(*options.record_max_seconds);
  if (options.record_files) {
    if (!options.record_max_bytes && !options.record_max_seconds) {
      error = "--record-files needs a limit (--record-max-bytes or --record-max-seconds)";
      return std::nullopt;
    }
    record.ring_files = *options.record_files;
  }
  return record;
}

nlohmann::ordered_json record_counters(const transports::RecordingStream& recording) {
  const transports::RecordCounters counters = recording.recorder()->counters();
  nlohmann::ordered_json report = {{"file", counters.file},
                                   {"packets", counters.packets},
                                   {"bytes", counters.bytes},
                                   {"dropped", counters.dropped_packets},
                                   {"lost", counters.lost_packets},
                                   {"files", counters.files},
                                   {"write_errors", counters.write_errors}};
  if (!counters.error.empty()) report["error"] = counters.error;
  return report;
}

void report_recording_losses(const transports::CaptureRecorder& recorder, std::string_view command) {
  const transports::RecordCounters counters = recorder.counters();
  const std::string head = "tether" + (command.empty() ? std::string() : " " + std::string(command)) + ": recording " +
                           recorder.options().file.string() + ": ";
  if (counters.dropped_packets > 0) {
    std::fprintf(stderr, "%s%llu packets dropped (the disk did not keep up)\n", head.c_str(),
                 static_cast<unsigned long long>(counters.dropped_packets));
  }
  if (!counters.error.empty()) {
    std::fprintf(stderr, "%sstopped: %s (%llu packets not recorded)\n", head.c_str(), counters.error.c_str(),
                 static_cast<unsigned long long>(counters.lost_packets));
  }
}

EndRecording::EndRecording(std::shared_ptr<transports::RecordingStream> recording, std::string_view command)
    : recording_(std::move(recording)), command_(command) {}

EndRecording::~EndRecording() {
  if (!recording_) return;
  transports::error_code ignored;
  recording_->close(ignored);
  recording_->recorder()->close();
  report_recording_losses(*recording_->recorder(), command_);
}

namespace {

enum class OptionParse { not_mine, consumed, error };

// Looks at argv[index]: a device option (and its value, `index` advanced past it) is stored in `options`;
// `error` gets the message of a bad value.
OptionParse parse_device_option(int argc, char** argv, int& index, DeviceOptions& options, std::string& error) {
  const std::string_view argument = argv[index];
  if (argument == "--no-reconnect") {
    options.reconnect = false;
    return OptionParse::consumed;
  }
  if (argument == "--force") {
    options.force = true;
    return OptionParse::consumed;
  }
  static constexpr std::string_view kWithValue[] = {"--port",   "--baud",   "--codec",  "--boot-wait", "--boot",
                                                    "--config", "--device", "--virtual", "--record",
                                                    "--record-max-bytes", "--record-max-seconds", "--record-files"};
  const CodecFlag* const flag = find_codec_flag(argument);
  if (flag == nullptr && std::find(std::begin(kWithValue), std::end(kWithValue), argument) == std::end(kWithValue)) {
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
    if (!options.codec) return bad(codec_choices());
  } else if (argument == "--boot-wait") {
    options.boot_wait_ms = parse_number(value, 0, 60000);
    if (!options.boot_wait_ms) return bad("milliseconds (0..60000)");
  } else if (argument == "--boot") {
    options.boot = transports::parse_boot_mode(value);
    if (!options.boot) return bad("detect, fixed or none");
  } else if (argument == "--config") {
    if (value.empty()) return bad("a file");
    options.config_file = value;
  } else if (argument == "--device") {
    if (value.empty()) return bad("a device name");
    options.device = value;
  } else if (argument == "--virtual") {
    if (value.empty()) return bad("a firmware image");
    options.firmware = value;
  } else if (argument == "--record") {
    if (value.empty()) return bad("a capture file");
    options.record = value;
  } else if (argument == "--record-max-bytes") {
    const auto bytes = parse_signed(value, 4096, std::int64_t{1} << 50);
    if (!bytes) return bad("bytes (4096 or more)");
    options.record_max_bytes = static_cast<std::uint64_t>(*bytes);
  } else if (argument == "--record-max-seconds") {
    options.record_max_seconds = parse_number(value, 1, 366u * 24 * 3600);
    if (!options.record_max_seconds) return bad("seconds (1 or more)");
  } else if (argument == "--record-files") {
    options.record_files = parse_number(value, 2, 1000);
    if (!options.record_files) return bad("a number 2..1000");
  } else {
    if (const auto expected = flag->check(value)) return bad(*expected);
    std::erase_if(options.codec_flags, [&](const auto& given) { return given.first == argument; });
    options.codec_flags.emplace_back(std::string(argument), std::string(value));
  }
  return OptionParse::consumed;
}

}  // namespace

bool parse_record_flag(int argc, char** argv, int& index, DeviceOptions& options, std::string& error) {
  static constexpr std::string_view kRecordFlags[] = {"--record", "--force", "--record-max-bytes",
                                                      "--record-max-seconds", "--record-files"};
  if (std::find(std::begin(kRecordFlags), std::end(kRecordFlags), std::string_view(argv[index])) ==
      std::end(kRecordFlags)) {
    return false;
  }
  parse_device_option(argc, argv, index, options, error);
  return true;
}

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

namespace {
// True when the codec's commands take the codec flag `name` (`--schema`).
bool takes_flag(const CodecCommands& commands, std::string_view name) {
  return std::any_of(commands.flags.begin(), commands.flags.end(), [name](const CodecFlag& flag) { return flag.name == name; });
}

// The codecs whose commands take the codec flag `name`, in the table's order.
std::vector<const devices::CodecRow*> codecs_taking(std::string_view name) {
  std::vector<const devices::CodecRow*> rows;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands != nullptr && takes_flag(*commands, name)) rows.push_back(row);
  }
  return rows;
}

// --codec; else, for --port or an image whose name says no codec, the one codec that takes a codec flag
// given (--schema: rpc), so the flag needs no --codec beside it.
std::optional<devices::Codec> given_codec(const DeviceOptions& options) {
  if (options.codec || !options.config_file.empty() || !options.device.empty()) return options.codec;
  if (!options.firmware.empty() && codec_row_of_image(firmware_image(options.firmware)) != nullptr) return std::nullopt;
  for (const auto& [given, value] : options.codec_flags) {
    const std::vector<const devices::CodecRow*> takers = codecs_taking(given);
    if (takers.size() == 1) return takers.front()->codec;
  }
  return std::nullopt;
}
}  // namespace

devices::Codec codec_of_arguments(int argc, char** argv, devices::Codec default_codec) {
  DeviceOptions options;
  for (int index = 1; index < argc; ++index) {
    if (std::string_view(argv[index]) == "--") break;  // what follows is the subcommand's, whatever it looks like
    std::string error;
    if (parse_device_option(argc, argv, index, options, error) == OptionParse::error) return default_codec;
  }
  options.codec = given_codec(options);
  options.codec_flags.clear();  // the codec's own subcommand checks them
  std::string error;
  const std::optional<DeviceTarget> target = resolve_device(options, default_codec, error);
  if (target) return target->config.codec;
  return options.codec.value_or(default_codec);  // `--codec rpc --help`: that codec's usage
}

namespace {
std::optional<DeviceTarget> resolve_target(const DeviceOptions& options, devices::Codec default_codec,
                                           std::string& error);
}  // namespace

std::optional<DeviceTarget> resolve_device(const DeviceOptions& options, devices::Codec default_codec,
                                           std::string& error) {
  std::optional<transports::RecordOptions> record = record_options(options, error);
  if (!error.empty()) return std::nullopt;
  std::optional<DeviceTarget> target = resolve_target(options, default_codec, error);
  // --record replaces the configuration's `record` (the device's own, else the rover's).
  if (target && record) target->config.record = record;
  return target;
}

namespace {
std::optional<DeviceTarget> resolve_target(const DeviceOptions& options, devices::Codec default_codec,
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
          std::pair{options.boot_wait_ms.has_value(), "--boot-wait"}, std::pair{options.boot.has_value(), "--boot"}}) {
      if (given) {
        error = std::string(name) + " does not apply with --config (the configuration sets it)";
        return std::nullopt;
      }
    }
    if (!options.codec_flags.empty()) {
      error = options.codec_flags.front().first + " does not apply with --config (the configuration sets it)";
      return std::nullopt;
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
        if (codec_commands(device.codec) == nullptr) {
          error = "device '" + device.name + "' speaks " + std::string(devices::to_string(device.codec)) +
                  ", which the tether command does not know (no row in its codec table)";
          return std::nullopt;
        }
        target.config = device;
        if (!target.config.record) target.config.record = rover.record;  // the rover's, for a device without its own
        if (auto* serial = std::get_if<devices::SerialTransport>(&target.config.transport); serial && !options.reconnect) {
          serial->options.reconnect.enabled = false;
        }
        target.label = device.name + " in " + options.config_file + " (devices[" + std::to_string(i) + "], " +
                       devices::describe(device.transport) + ", " + std::string(devices::to_string(device.codec)) + ")";
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
    if (options.boot_wait_ms || options.boot) {
      error = std::string(options.boot ? "--boot" : "--boot-wait") +
              " does not apply to --virtual (the board is ready when it opens)";
      return std::nullopt;
    }
  }
  const std::filesystem::path firmware = board ? firmware_image(options.firmware) : std::filesystem::path();
  if (board) {
    // Before the codec, which the image's name suggests: a missing image is "not found", not a codec mismatch.
    if (std::optional<std::string> problem = firmware_image_problem(firmware)) {
      error = std::move(*problem);
      return std::nullopt;
    }
  }
  const std::optional<devices::Codec> chosen = given_codec(options);
  const devices::Codec codec = chosen ? *chosen : (board ? codec_of_image(firmware) : default_codec);
  const CodecCommands& commands = *codec_commands(codec);  // parse_codec and codec_of_image name rows it has
  for (const auto& [given, value] : options.codec_flags) {
    if (takes_flag(commands, given)) continue;
    std::string codecs;
    for (const devices::CodecRow* row : codecs_taking(given)) {
      codecs += (codecs.empty() ? "" : " or ") + std::string(row->name);
    }
    error = given + " applies to the " + codecs + " codec only";
    return std::nullopt;
  }
  const std::uint32_t baud = options.baud.value_or(devices::codec_row(codec).default_baud);
  const bool detects = devices::codec_row(codec).boot.usable();
  if (options.boot == transports::BootMode::detect && !detects) {
    error = "--boot detect: codec " + std::string(devices::to_string(codec)) +
            "'s firmware announces nothing at boot and has no probe (use --boot fixed)";
    return std::nullopt;
  }
  target.config.codec = codec;
  try {
    target.config.options = commands.default_options(baud, options);
  } catch (const devices::ConfigError& failure) {  // a codec flag's file that does not read
    error = failure.what();
    return std::nullopt;
  }
  if (port) {
    devices::SerialTransport serial;
    serial.path = options.port;
    serial.options = transports::SerialOptions();
    serial.options.baud = baud;
    serial.options.boot_wait = std::chrono::milliseconds(options.boot_wait_ms.value_or(0));
    serial.options.boot = options.boot.value_or(detects ? transports::BootMode::detect : transports::BootMode::fixed);
    serial.options.reconnect.enabled = options.reconnect;
    target.config.name = options.port;
    target.config.transport = serial;
  } else if (commands.lone_virtual_board) {
    commands.lone_virtual_board(firmware, options, target.config);
  } else {
    devices::VirtualTransport virt;
    virt.board.firmware = firmware;
    virt.board.pacing = transports::Pacing::real_time;
    virt.board.name = firmware.stem().string();
    target.config.name = virt.board.name;
    target.config.transport = virt;
  }
  target.label = devices::describe(target.config.transport) + " (" + std::string(devices::to_string(codec)) + ")";
  return target;
}
}  // namespace

nlohmann::ordered_json OpenDevice::counters() const {
  nlohmann::ordered_json counters = codec_commands(codec())->counters(client());
  if (port_ && port_->options().reconnect.enabled) {
    const transports::LinkCounters link = port_->link_counters();
    counters["port"] = {{"disconnects", link.disconnects},
                        {"reconnects", link.reconnects},
                        {"time_down_ms", link.time_down.count()}};
  }
  if (recording_) counters["record"] = record_counters(*recording_);
  if (port_ && port_->options().boot != transports::BootMode::none && port_->options().boot_wait.count() > 0) {
    // The last open's (a re-open's after an outage): how long the board took to be ready, and how it said so.
    const transports::BootReport boot = port_->boot_report();
    counters["boot"] = {{"mode", transports::to_string(boot.mode)},
                        {"outcome", transports::to_string(boot.outcome)},
                        {"ready_after_ms", boot.ready_after.count()},
                        {"probes", boot.probes}};
  }
  return counters;
}

nlohmann::ordered_json stats_report(const OpenDevice& device, double seconds, const nlohmann::ordered_json& extra) {
  nlohmann::ordered_json report = {{"device", device.description()},
                                   {"codec", std::string(devices::to_string(device.codec()))},
                                   {"seconds", std::round(seconds * 1000.0) / 1000.0}};
  const nlohmann::ordered_json counters = device.counters();
  for (const auto& [key, value] : counters.items()) report[key] = value;
  for (const auto& [key, value] : extra.items()) report[key] = value;
  return report;
}

void OpenDevice::close() {
  if (rover_) {
    std::call_once(*close_once_, [this] {
      rover_->close();  // closes the capture file too
      if (recording_) report_recording_losses(*recording_->recorder(), "");
    });
  }
}

namespace {

// While alive, closes the stream an opening made as soon as `stopped()` holds (looked at every 50 ms on a
// thread of its own): the opening then fails at once, with the link's error.
class CloseOnStop {
 public:
  explicit CloseOnStop(std::function<bool()> stopped) {
    if (!stopped) return;
    watcher_ = std::thread([this, stopped = std::move(stopped)] {
      std::unique_lock lock(mutex_);
      while (!done_) {
        if (stream_ && stopped()) {
          stream_->close();  // thread-safe: runs on the stream's strand
          return;
        }
        changed_.wait_for(lock, std::chrono::milliseconds(50));
      }
    });
  }
  ~CloseOnStop() {
    if (!watcher_.joinable()) return;
    {
      const std::lock_guard lock(mutex_);
      done_ = true;
    }
    changed_.notify_all();
    watcher_.join();
  }
  CloseOnStop(const CloseOnStop&) = delete;
  CloseOnStop& operator=(const CloseOnStop&) = delete;

  /// The opening's `wrap_stream`: remembers the stream, changes nothing.
  std::shared_ptr<transports::ByteStream> watch(std::shared_ptr<transports::ByteStream> stream) {
    const std::lock_guard lock(mutex_);
    stream_ = stream;
    return stream;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool done_ = false;
  std::shared_ptr<transports::ByteStream> stream_;
  std::thread watcher_;
};

// A serial port that is not there (yet): what a port that reconnects waits for.
bool port_missing(const transports::error_code& code) {
  return code == boost::system::errc::no_such_file_or_directory || code == boost::system::errc::no_such_device ||
         code == boost::system::errc::no_such_device_or_address || code == transports::TransportError::no_matching_port;
}

}  // namespace

std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                      const ClientHooks& hooks, Progress& progress, std::string& error) {
  transports::error_code code;
  return open_device(target, std::move(executor), hooks, progress, error, code);
}

std::optional<OpenDevice> open_device_within(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                             const ClientHooks& hooks, Progress& progress,
                                             std::chrono::steady_clock::time_point deadline, std::string& error) {
  const auto* serial = std::get_if<devices::SerialTransport>(&target.config.transport);
  const bool waits = serial != nullptr && serial->options.reconnect.enabled;
  const auto started = std::chrono::steady_clock::now();
  std::chrono::milliseconds delay(50);
  for (;;) {
    transports::error_code code;
    std::string failure;
    auto opened = open_device(target, executor, hooks, progress, failure, code);
    if (opened) return opened;
    const auto now = std::chrono::steady_clock::now();
    if (!waits || !port_missing(code) || now >= deadline) {
      error = failure;
      if (waits && port_missing(code)) {
        const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(now - started);
        error += "; waited " + std::to_string(waited.count()) + " ms for it (the call's budget)";
      }
      return std::nullopt;
    }
    progress.show("waiting for " + devices::describe(target.config.transport) + " to appear...");
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(delay, deadline - now));
    delay = std::min(delay * 2, std::chrono::milliseconds(1000));
  }
}

bool wait_for_port(const OpenDevice& device, std::chrono::steady_clock::time_point deadline, Progress& progress) {
  const auto& port = device.port();
  if (!port || port->link_counters().up) return true;
  progress.show("waiting for " + port->path() + " to come back...");
  // The port re-opens by itself (its supervision polls, backing off to 1 s); a look every 10 ms sees it.
  while (!port->link_counters().up) {
    if (port->link_counters().gave_up || std::chrono::steady_clock::now() >= deadline) {
      progress.clear();
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  progress.clear();
  return true;
}

std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                      const ClientHooks& hooks, Progress& progress, std::string& error,
                                      transports::error_code& code) {
  // The progress line goes away however opening ends (the caller prints the error or the first output).
  struct ClearProgress {
    Progress& progress;
    ~ClearProgress() { progress.clear(); }
  } clear_progress{progress};
  OpenDevice opened;
  opened.description_ = target.label;

  // The devices library opens it as a rover service would (boot wait, random first Romi id, proxy inits and
  // handshake, rings); the hooks are attached as soon as the client exists, so no event is missed.
  devices::RoverConfig rover_config;
  rover_config.devices.push_back(target.config);
  devices::OpenOptions open_options;
  open_options.on_client = [&](const devices::RoverDevice& device) {
    if (hooks.on_client) hooks.on_client(device.client);
    if (const CodecCommands* commands = codec_commands(device.codec); commands != nullptr && !commands->readying.empty()) {
      progress.show(std::string(commands->readying));
    }
  };
  CloseOnStop close_on_stop(hooks.stopped);
  if (hooks.stopped) {
    open_options.wrap_stream = [&close_on_stop](const devices::DeviceConfig&, std::shared_ptr<transports::ByteStream> stream) {
      return close_on_stop.watch(std::move(stream));
    };
  }
  progress.show("opening " + devices::describe(target.config.transport) + "...");
  try {
    opened.rover_ = std::make_shared<devices::Rover>(devices::open_rover(rover_config, executor, open_options));
    opened.codec_ = opened.rover_->devices().front().codec;
    opened.client_ = opened.rover_->devices().front().client;
    opened.port_ = opened.rover_->devices().front().port;
    opened.recording_ = opened.rover_->devices().front().recording;
  } catch (const devices::ConfigError& failure) {
    error = failure.detail();  // the JSON path of a one-device rover would only confuse (--port, --virtual)
    // The transport's cause only: a capture file's missing folder is not a port to wait for.
    if (failure.path().find(".transport") != std::string::npos) code = failure.code();
    return std::nullopt;
  }
  return opened;
}

std::shared_ptr<transports::ByteStream> open_stream(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                                    Progress& progress, std::string& error) {
  progress.show("opening " + devices::describe(target.config.transport) + "...");
  std::shared_ptr<transports::ByteStream> stream;
  try {
    // The capture file first: one that may not be written fails before the device resets.
    std::shared_ptr<transports::CaptureRecorder> recorder;
    if (target.config.record) {
      transports::error_code code;
      recorder = transports::CaptureRecorder::open(*target.config.record, code, error);
      if (!recorder) {
        progress.clear();
        return nullptr;
      }
    }
    // A ring's boards live as long as its stream.
    try {
      stream = devices::open_transport(target.config, std::move(executor)).stream;
    } catch (const devices::ConfigError&) {
      if (recorder) recorder->discard_if_empty();  // opening again must not find it
      throw;
    }
    if (recorder) stream = devices::record_stream(target.config, std::move(stream), std::move(recorder));
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
