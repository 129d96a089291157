/// @file config.hpp
/// A rover's devices as an application configures them: a JSON document (schema in docs/config.md) parsed
/// into typed structs, one `DeviceConfig` per device: its name, its transport (serial port, ser2net over
/// TCP, a virtual Uno, a virtual ring of Unos), its codec (`romi`, `proxy`, `proxy-compat`, `elcano`, `rpc`) and
/// the codec's options.
///
/// @code
///   devices::ParseOptions where;
///   where.firmware_dir = TETHER_FIRMWARE_DIR;                       // for "firmware": "romi-test"
///   devices::RoverConfig config = devices::load_config("/etc/rover/rover.json", where);
///   devices::Rover rover = devices::open_rover(config, io.get_executor());   // rover.hpp
/// @endcode
///
/// ## Errors
/// Everything that is wrong with a configuration is a `ConfigError`: parsing (`parse_config`,
/// `load_config`) and opening (`open_rover`, see rover.hpp) alike. Its `path()` is the JSON path of the
/// offending value (`devices[1].transport.serial.baud`) and `what()` says what was expected:
///   - `devices[1].transport.serial.baud: expected an unsigned integer, got string "fast"`
///   - `devices[0].codec: unknown codec "mavlink" (expected one of romi, proxy, proxy-compat, elcano, rpc)`
///   - `devices[2].transport.serial: missing key "path"`
///   - `devices[0].options: unknown key "atempt_timeout_ms" (did you mean "attempt_timeout_ms"?)`
///   - `devices[3].name: duplicate device name "arm" (also devices[0])`
///   - at open time: `devices[1].transport.serial.path: /dev/ttyUSB9: No such file or directory`
/// Unknown keys are errors everywhere (a misspelt option silently ignored is a field bug); a close match
/// is suggested. Parsing never touches a device, and the file system only to read `load_config`'s file and
/// what a codec's options name as read at parse time (an rpc device's `schema`, relative to
/// `ParseOptions::base_dir`): ports and firmware images are checked when the rover opens.
///
/// ## Firmware images
/// A virtual board's `firmware` is either a path (absolute, or relative to `ParseOptions::base_dir`: the
/// config file's folder for `load_config`) or a bare image name (`romi-test`, `proxy.elf`: no `/`) looked
/// up in `ParseOptions::firmware_dir` as `<dir>/<name>.elf`. The library knows no firmware folder of its
/// own: tools pass the build's (`TETHER_FIRMWARE_DIR`).
#pragma once

#include <boost/system/error_code.hpp>

#include <nlohmann/json_fwd.hpp>

#include <any>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "tether/transports/recording.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/serial_ports.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::devices {

/// Error codes of the devices library (boost::system, like the transports and clients).
using error_code = boost::system::error_code;

/// What went wrong, when it is not the transport's or the OS's own error.
enum class DevicesError {
  invalid_config = 1,  ///< The configuration is malformed or inconsistent (a `ConfigError` from parsing).
  unknown_device,      ///< No device of that name.
  wrong_codec,         ///< The device exists but speaks another codec.
  not_supported,       ///< The configuration is valid but this build cannot open it (yet).
  device_not_ready,    ///< The device opened but did not answer its handshake in time.
};

/// The "tether.devices" category.
const boost::system::error_category& devices_category();
/// Makes an error_code of the "tether.devices" category.
error_code make_error_code(DevicesError error);

/// A configuration that cannot be parsed or opened. `what()` is `<path>: <detail>` (prefixed with the
/// file name for `load_config`), e.g. `devices[1].transport.serial.baud: expected an unsigned integer,
/// got string "fast"`.
class ConfigError : public std::runtime_error {
 public:
  /// Error at JSON path `path` (empty: the document itself) with `detail` (what was expected, or what the
  /// OS said), `code` the machine-readable cause (`DevicesError::invalid_config` for parse errors, the
  /// transport's error at open time) and `file` the configuration file, if any.
  ConfigError(std::string path, std::string detail, error_code code = make_error_code(DevicesError::invalid_config),
              std::string file = {});

  /// JSON path of the offending value: `devices[1].transport.serial.baud`; empty for the document itself.
  const std::string& path() const { return path_; }
  /// What was expected or what failed, without the path.
  const std::string& detail() const { return detail_; }
  /// Machine-readable cause.
  const error_code& code() const { return code_; }
  /// The configuration file (`load_config`), else empty.
  const std::string& file() const { return file_; }

 private:
  std::string path_;
  std::string detail_;
  error_code code_;
  std::string file_;
};

/// The protocol a device speaks: the value of a row of the codec table (codecs.hpp). A codec plugin declares
/// its own beside its options (`romi::kCodec`, `proxy::kCodec`, `proxy::kCompatCodec`, `elcano::kCodec`:
/// below 16, one each, checked when the table is built); a codec a program registers gets one assigned
/// (`register_codec`, 16 and up). `Codec{}` (0) is the Romi codec's.
enum class Codec : std::uint8_t {};

/// The codec's name in configurations: `romi`, `proxy`, `proxy-compat`, `elcano` (its row's `name`;
/// `unknown` for a value no row has).
std::string_view to_string(Codec codec);

/// A serial port (`{"serial": {...}}`).
struct SerialTransport {
  /// Device path: `/dev/ttyACM0`, `/dev/serial/by-id/...`. May be empty when `usb` or `by_id` names the board.
  std::string path;
  /// Baud, boot wait, banner, exclusivity, latency, HUPCL. The parser starts from
  /// `SerialOptions::arduino_uno()` (2 s boot wait) and the codec's baud (57600 for proxy-compat, else
  /// 115200).
  transports::SerialOptions options = transports::SerialOptions::arduino_uno();
  /// The board's USB identity (`"port": {"usb": {"vid", "pid", "serial"}}`, any subset): the port is looked
  /// up when the device opens and again after it vanished (serial_ports.hpp); a `path` given as well must
  /// be one of the matches. (After `options`, initialised: `SerialTransport{path, options}` still builds.)
  transports::UsbIdentity usb = {};
  /// A `/dev/serial/by-id` name (`"port": {"by_id": "usb-Arduino..."}`), looked up like `usb`.
  std::string by_id = {};

  /// `path`, `usb` and `by_id` as one `transports::PortSpec`.
  transports::PortSpec port() const { return transports::PortSpec{path, usb, by_id}; }
};

/// A TCP-serial bridge such as ser2net (`{"tcp": {...}}`).
struct TcpTransport {
  std::string host;                                      ///< Host name or address.
  std::uint16_t port = 0;                                ///< TCP port (1..65535).
  std::chrono::milliseconds connect_timeout{5000};       ///< Resolve + connect limit.
};

/// One simulated Arduino Uno running a firmware image (`{"virtual": {...}}`). The rover owns the board.
struct VirtualTransport {
  /// `firmware` (resolved path), `pacing`, `seed`, `to_mcu_faults`, `from_mcu_faults`; the board's `name`
  /// is the device's.
  transports::VirtualUnoOptions board;
};

/// One board of a virtual ring.
struct RingBoardConfig {
  /// Resolved image path (default: the codec row's `ring_board_image`, codecs.hpp).
  std::filesystem::path firmware;
  /// Initial EEPROM from address 0 (at most 1024 bytes; empty: the simulator's blank EEPROM). A settings
  /// object in a configuration (`"eeprom": {...}`) is the codec's to read: its row's `ring_board_settings`
  /// encodes it here when the configuration is parsed.
  std::vector<std::uint8_t> eeprom;
};

/// A ring of simulated Unos wired TX to RX in order (`{"virtual_ring": {...}}`, for a codec whose row says
/// `VirtualBoards::ring`: elcano). The host
/// writes to the first board and reads from the last, as it would through one USB-serial adapter on a real
/// ring. The rover owns the boards.
struct VirtualRingTransport {
  std::vector<RingBoardConfig> boards;                   ///< In ring order, at least one.
  transports::Pacing pacing = transports::Pacing::real_time;  ///< The group's pacing.
  std::uint64_t seed = 0;                                ///< Seed of every board (fault models, power-up RAM).
};

/// How a device is reached.
using TransportConfig = std::variant<SerialTransport, TcpTransport, VirtualTransport, VirtualRingTransport>;

/// One line describing a transport: `serial /dev/ttyACM0 115200`, `tcp rover-pi:4001`,
/// `virtual romi-test.elf (real_time, seed 0)`, `virtual ring of 3 boards (elcano-node.elf)`.
std::string describe(const TransportConfig& transport);

/// A device's codec options: a value of the options type its codec defines (`romi::DeviceOptions`,
/// `proxy::DeviceOptions`, `elcano::DeviceOptions`, or a registered codec's own), reached by that type. Every codec,
/// built in or registered (codecs.hpp), stores and reads its options the same way:
///
/// @code
///   devices::CodecOptions options = romi::DeviceOptions{};
///   if (auto* romi = options.get_if<romi::DeviceOptions>()) romi->first_id = 7;
///   const auto& same = options.get<romi::DeviceOptions>();   // throws std::invalid_argument if not
/// @endcode
class CodecOptions {
 public:
  /// No options (what a codec's parser replaces; a device is never opened with none).
  CodecOptions() = default;
  /// Holds `options`, any copyable type.
  template <typename Options,
            typename = std::enable_if_t<!std::is_same_v<std::decay_t<Options>, CodecOptions>>>
  CodecOptions(Options&& options)  // NOLINT: implicit: `device.options = romi::DeviceOptions{}`
      : value_(std::forward<Options>(options)) {}

  /// The options if they are an `Options`, else null.
  template <typename Options>
  const Options* get_if() const {
    return std::any_cast<Options>(&value_);
  }
  /// The options if they are an `Options`, else null.
  template <typename Options>
  Options* get_if() {
    return std::any_cast<Options>(&value_);
  }
  /// The options as an `Options`. Throws `std::invalid_argument` when they are of another type.
  template <typename Options>
  const Options& get() const {
    if (const Options* options = get_if<Options>()) return *options;
    throw std::invalid_argument("devices::CodecOptions: the options are of another codec's type");
  }
  /// The options as an `Options`. Throws `std::invalid_argument` when they are of another type.
  template <typename Options>
  Options& get() {
    if (Options* options = get_if<Options>()) return *options;
    throw std::invalid_argument("devices::CodecOptions: the options are of another codec's type");
  }
  /// True when options are held.
  bool has_value() const { return value_.has_value(); }

 private:
  std::any value_;
};

/// One device of the rover.
struct DeviceConfig {
  std::string name;           ///< Unique within the rover, non-empty.
  Codec codec{};  ///< Protocol (a plugin's `kCodec`, or a registered codec's value).
  TransportConfig transport;  ///< How it is reached.
  CodecOptions options;       ///< The codec's options (defaults when the document gives none).
  /// Record this device's link into a capture file of its own (`"record": "FILE"`, docs/captures.md); unset:
  /// into the rover's (`RoverConfig::record`) if it has one, else not recorded.
  std::optional<transports::RecordOptions> record = std::nullopt;
};

/// Every device of a rover, in the document's order (the order they open in).
struct RoverConfig {
  std::string name;                  ///< Optional rover name (logs).
  std::vector<DeviceConfig> devices; ///< At least one.
  /// Record every device's link that has no `record` of its own into this one capture file, one interface
  /// per device (`"record"` at the top level).
  std::optional<transports::RecordOptions> record = std::nullopt;
};

/// Where firmware names and relative paths resolve.
struct ParseOptions {
  /// Folder of the firmware images, for bare names (`romi-test` -> `<dir>/romi-test.elf`). Empty: bare
  /// names are an error.
  std::filesystem::path firmware_dir;
  /// Folder relative firmware paths (`images/x.elf`) and files named in codec options (an rpc device's
  /// `schema`) are relative to. Empty: the current directory.
  std::filesystem::path base_dir;
};

/// Largest configuration text accepted (1 MiB): a rover's is a few KB. Bounds the time and memory of a
/// parse (a 52 MB file once took 16 s and ~1 GB) and whatever else reads it; more is a `ConfigError`.
inline constexpr std::size_t kMaxConfigBytes = std::size_t{1} << 20;
/// Deepest nesting of objects and arrays accepted (a rover's configuration is 5 levels deep); deeper text
/// is a `ConfigError` found before any document is built, so time and memory stay linear in the text.
inline constexpr std::size_t kMaxConfigDepth = 64;

/// Parses a JSON document. Throws `ConfigError` (path and expectation; JSON syntax errors with line and
/// column; a key given twice in one object, with its path; text over `kMaxConfigBytes` or nested deeper
/// than `kMaxConfigDepth`).
RoverConfig parse_config(std::string_view json_text, const ParseOptions& options = ParseOptions());
/// Parses an already-parsed JSON document (e.g. one section of a larger application config). Throws
/// `ConfigError`. Duplicate keys are the caller's parser's business (nlohmann keeps the last).
RoverConfig parse_document(const nlohmann::json& document, const ParseOptions& options = ParseOptions());
/// Reads and parses `file`; `base_dir` defaults to the file's folder. Throws `ConfigError` whose `file()`
/// is the file (an unreadable file, a directory, a file over `kMaxConfigBytes`: an empty path and the
/// reason, e.g. `Is a directory`). Reads at most `kMaxConfigBytes` + 1 bytes, also from a device or a pipe.
RoverConfig load_config(const std::filesystem::path& file, ParseOptions options = ParseOptions());

/// Device names for an error message ("no device 'x' (devices: ...)"): each JSON-quoted (a NUL or a
/// control character is escaped, never cuts the message short), comma-separated, the first
/// `kListed` only, then how many more: the message stays short whatever the rover's size.
class NameList {
 public:
  /// Names shown at most.
  static constexpr std::size_t kListed = 10;
  /// Adds a name.
  void add(std::string_view name);
  /// `"arm", "servos"` or `"a", ..., "j" and 5 more`.
  std::string text() const;

 private:
  std::size_t count_ = 0;
  std::string listed_;
};

/// Checks what parsing guarantees, for configurations built in code: devices present, names unique and
/// non-empty, options matching the codec, transport allowed for the codec, timing values usable. Throws
/// `ConfigError`. `open_rover` calls it.
void validate(const RoverConfig& config);

/// The virtual rover of docs/examples/rover-virtual.json (embedded at build time): one device per codec
/// on simulated Unos. Parse it with a `firmware_dir`.
std::string_view default_virtual_rover_config();

}  // namespace tether::devices

/// Lets `DevicesError` values convert to `error_code`.
template <>
struct boost::system::is_error_code_enum<tether::devices::DevicesError> : std::true_type {};
