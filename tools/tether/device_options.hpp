// Device selection shared by `call`, `send`, `shell`, `monitor` and `stats`: the options that name a device
// (`--port PATH ...`, `--config FILE --device NAME`, `--virtual FIRMWARE`), turning them into a
// `devices::DeviceConfig`, and opening it: as a raw byte stream (monitor) or with its codec's client.
#pragma once

#include <boost/asio/any_io_executor.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/recording.hpp"
#include "tether/transports/serial_port_stream.hpp"

namespace tether::cli {

/// The device options as given on the command line.
struct DeviceOptions {
  /// Which way the device was named.
  enum class Source { none, port, config, virtual_board };
  Source source = Source::none;
  std::string port;                              ///< --port
  std::optional<std::uint32_t> baud;             ///< --baud
  std::optional<devices::Codec> codec;           ///< --codec
  std::optional<std::uint32_t> boot_wait_ms;     ///< --boot-wait
  std::optional<transports::BootMode> boot;      ///< --boot
  std::string config_file;                       ///< --config
  std::string device;                            ///< --device
  std::string firmware;                          ///< --virtual
  bool reconnect = true;                         ///< false: --no-reconnect (a serial port that vanishes ends the link)
  std::string record;                            ///< --record (monitor: --write): the capture file
  bool force = false;                            ///< --force: --record may overwrite an existing file
  std::optional<std::uint64_t> record_max_bytes;   ///< --record-max-bytes
  std::optional<std::uint32_t> record_max_seconds; ///< --record-max-seconds
  std::optional<std::uint32_t> record_files;       ///< --record-files
  /// The flags only some codecs take (their rows' `CodecCommands::flags`, `--generation D`), as given and
  /// in that order; each value already passed its flag's check.
  std::vector<std::pair<std::string, std::string>> codec_flags;

  /// The value given to the codec flag `name` (`--capture`), or null.
  const std::string* codec_flag(std::string_view name) const {
    for (const auto& [flag, value] : codec_flags) {
      if (flag == name) return &value;
    }
    return nullptr;
  }
};

/// The usage text of the device options (for the subcommands' usage); `--codec` lists every codec with rows.
/// `port_codec`: the codec of a `--port` without `--codec` when the command has its own (send: proxy);
/// empty: the default codec's.
std::string device_usage(std::string_view port_codec = {});

/// `parse_arguments` for a subcommand that names a device: `--help`, then the device options (stored in
/// `options`; a bad value is a usage error), then `handle` for the subcommand's own arguments.
std::optional<int> parse_device_arguments(int argc, char** argv, const CommandText& text, DeviceOptions& options,
                                          const ArgumentHandler& handle);

/// The device to open: its configuration (built from --port / --virtual, or read from --config) and a
/// label for messages.
struct DeviceTarget {
  devices::DeviceConfig config;
  std::string label;  ///< `serial /dev/pts/3 115200 (romi)`, `arm in rover.json (devices[0])`
};

/// Checks the options (exactly one way of naming a device, no option that does not apply) and builds the
/// target. Nothing on failure, with `error` set (a usage error: exit status 2).
/// `default_codec` is the codec of a `--port` without `--codec` (romi for most subcommands, proxy for send).
std::optional<DeviceTarget> resolve_device(const DeviceOptions& options, devices::Codec default_codec,
                                           std::string& error);

/// The codec of the device that `argv[1..]`'s device options name (before a `--`), without a word of
/// output: `default_codec` when they name none or do not resolve (the subcommand's own parsing then says
/// why). `tether call` picks the codec's call with it before any argument is parsed.
devices::Codec codec_of_arguments(int argc, char** argv, devices::Codec default_codec);

/// Callbacks installed when the client is created, so they see every event from the first byte on.
struct ClientHooks {
  /// Called with the new client, before it gets ready (proxy handshake and inits): attach event handlers.
  std::function<void(const devices::DeviceClient& client)> on_client;
  /// Looked at every 50 ms while the device opens (a stop signal's flag): once it returns true the device's
  /// link is closed, so the opening ends at once instead of waiting out a proxy handshake.
  std::function<bool()> stopped;
};

/// An opened device with its codec's client: a rover of one device (`devices::open_rover`), so the command
/// opens a device the way a rover service does.
class OpenDevice {
 public:
  /// The codec.
  devices::Codec codec() const { return codec_; }
  /// One line: `serial /dev/pts/3 115200 (romi)`.
  const std::string& description() const { return description_; }
  /// The client of the codec.
  const devices::DeviceClient& client() const { return client_; }
  /// The client as `Client` (`romi::Client`), or null when the codec has another.
  template <typename Client>
  std::shared_ptr<Client> client_as() const {
    return client_.get<Client>();
  }
  /// The serial port of a serial device (its link events and outage counters), else null.
  const std::shared_ptr<transports::SerialPortStream>& port() const { return port_; }
  /// The recording of the link (--record, or the configuration's `record`), else null.
  const std::shared_ptr<transports::RecordingStream>& recording() const { return recording_; }
  /// The client's counters: `{"link": {...}, "proxy"/"ring": {...}, ...}` (the codec row's `counters`), and
  /// for a supervised serial port `"port": {"disconnects", "reconnects", "time_down_ms"}`.
  nlohmann::ordered_json counters() const;
  /// Closes the client (and the device); idempotent, and safe from a stop-signal action while another
  /// thread still reads the client or its counters (they stay readable after the close).
  void close();

 private:
  friend std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                               const ClientHooks& hooks, Progress& progress, std::string& error,
                                               transports::error_code& code);
  // Copies of the rover's one device: the rover forgets its devices when it closes.
  devices::Codec codec_{};
  devices::DeviceClient client_;
  std::string description_;
  std::shared_ptr<transports::SerialPortStream> port_;
  std::shared_ptr<transports::RecordingStream> recording_;
  std::shared_ptr<devices::Rover> rover_;
  std::shared_ptr<std::once_flag> close_once_ = std::make_shared<std::once_flag>();
};

/// Opens the device and creates its client: romi (random first id unless the options set one), proxy (waits for
/// the session handshake in primary mode and for the configured inits, within the device's open timeout),
/// elcano (the host's ring node). Blocks; another thread must run `executor`. Nothing on failure, with
/// `error` set (exit status 2).
std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                      const ClientHooks& hooks, Progress& progress, std::string& error);

/// `open_device` that also gives the cause of a failure in `code` when the transport failed (ENOENT, ...; clear
/// when something else did, such as the capture file).
std::optional<OpenDevice> open_device(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                      const ClientHooks& hooks, Progress& progress, std::string& error,
                                      transports::error_code& code);

/// `open_device` for a command with a budget (`tether call`): while the device's serial port is missing
/// (no such path, or no port with its identity) and its transport reconnects (not `--no-reconnect`), it
/// tries again, backing off from 50 ms to at most 1 s, until `deadline`; a progress line says it waits.
/// `error` then ends with how long it waited. Any other failure, or a transport that does not reconnect,
/// fails at once as `open_device` does.
std::optional<OpenDevice> open_device_within(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                             const ClientHooks& hooks, Progress& progress,
                                             std::chrono::steady_clock::time_point deadline, std::string& error);

/// Waits until `device`'s supervised serial port is back (true at once when it is up, or not a serial
/// port), at most until `deadline`; a progress line says it waits.
bool wait_for_port(const OpenDevice& device, std::chrono::steady_clock::time_point deadline, Progress& progress);

/// The usage lines of --record and its limits (in `device_usage`; `write_flag` names the file flag: `--record
/// FILE`, monitor's `--write FILE`).
std::string record_usage(std::string_view write_flag = "--record");

/// Takes argv[index] when it is a recording flag (`--record FILE`, `--force`, `--record-max-bytes N`,
/// `--record-max-seconds S`, `--record-files N`; `index` advanced past its value) into `options`, for the
/// commands that hold a whole rover instead of one device (demo, bench). Returns true when it took the flag;
/// `error` is then the usage error of a bad value, if any.
bool parse_record_flag(int argc, char** argv, int& index, DeviceOptions& options, std::string& error);

/// The recording options of `--record FILE` (with `--force` and the limits), or nothing without --record.
/// `error` when a limit or --force is given without --record.
std::optional<transports::RecordOptions> record_options(const DeviceOptions& options, std::string& error);

/// Ends a recording when it goes out of scope: closes the stream and the recorder (the file is complete), and
/// says on stderr how many packets were dropped or lost and why recording stopped, if it did.
class EndRecording {
 public:
  /// For `recording` (null: nothing to do) of `tether <command>`.
  EndRecording(std::shared_ptr<transports::RecordingStream> recording, std::string_view command);
  ~EndRecording();
  EndRecording(const EndRecording&) = delete;
  EndRecording& operator=(const EndRecording&) = delete;

 private:
  std::shared_ptr<transports::RecordingStream> recording_;
  std::string command_;
};

/// Says on stderr (`tether <command>: recording FILE: 12 packets dropped (the disk was too slow)`) what a
/// recording lost, if anything.
void report_recording_losses(const transports::CaptureRecorder& recorder, std::string_view command);

/// The counters of a recording for `stats` and the shell's `:stats`: `{"file", "packets", "dropped", ...}`.
nlohmann::ordered_json record_counters(const transports::RecordingStream& recording);

/// Opens only the device's byte stream (no client: nothing is sent), recorded when the target says so (the
/// result is then a `transports::RecordingStream`; closing it and its recorder ends the file). Virtual rings
/// are not supported.
std::shared_ptr<transports::ByteStream> open_stream(const DeviceTarget& target, boost::asio::any_io_executor executor,
                                                    Progress& progress, std::string& error);

/// What `tether stats` and the shell's `:stats` print: `{"device": ..., "codec": ..., "seconds": ...}` plus
/// the client's counters (`OpenDevice::counters()`) plus `extra`'s entries.
nlohmann::ordered_json stats_report(const OpenDevice& device, double seconds,
                                    const nlohmann::ordered_json& extra = nlohmann::ordered_json::object());

/// Renders a counters report (nested JSON objects of numbers, strings and booleans) as an aligned table:
/// top-level values as `key  value`, objects as a heading followed by their indented entries.
std::string counters_table(const nlohmann::ordered_json& report);

/// The rover `demo` and `bench` run: `config_file`'s (none: the virtual rover, or the command's default when
/// nothing is recorded either), with every device recorded into `record.file` when it names one (one
/// interface each; the configuration's own `record` keys give way). Throws `devices::ConfigError`.
std::optional<devices::RoverConfig> rover_to_run(const std::string& config_file,
                                                 const std::filesystem::path& firmware_dir,
                                                 const transports::RecordOptions& record);

/// The firmware folder: $TETHER_FIRMWARE_DIR, else the images installed with this binary
/// (`<prefix>/share/tether/firmware`), else the build's.
std::string firmware_dir();

/// The image a command line names, for `--virtual` and `tether sim` alike: a path when it contains a `/`
/// (`build/firmware/echo.elf`, `./mine.elf`), else an image name looked up in `firmware_dir()`, `.elf`
/// optional (`romi-test`, `romi-test.elf`).
std::filesystem::path firmware_image(const std::string& name);

/// Why `firmware` cannot be a firmware image (`firmware image not found: ...`, `not a firmware image: ... is a
/// FIFO ...`), or nothing when it is a regular file.
std::optional<std::string> firmware_image_problem(const std::filesystem::path& firmware);

}  // namespace tether::cli
