/// @file codecs.hpp
/// The codec table: one row per protocol a device can speak, read by everything that handles a device by
/// its codec (the configuration parser and validator, `open_rover`, the `tether` command and the demo, which
/// add their own columns: tools/tether/codec_commands.hpp). A new protocol is a folder (codecs/<name>/) and
/// one row; how to add one: docs/codecs.md, "Adding a codec".
///
/// The built-in rows are `romi`, `proxy`, `proxy-compat`, `elcano` and `rpc`. A program registers more at start-up
/// (`register_codec`, before any configuration is parsed): its configurations then name the codec like the
/// built-in ones, options checked against the row's keys, the device opened through the row's `open`:
///
/// @code
///   devices::CodecRow row;
///   row.name = "line-echo";
///   row.option_keys = {"timeout_ms"};
///   row.parse_options = [](const devices::OptionsContext& context) -> devices::CodecOptions {
///     return LineEchoOptions{...};                        // any copyable type
///   };
///   row.open = [](std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
///                 std::shared_ptr<client::LinkClock> clock) -> devices::DeviceClient {
///     return std::make_shared<LineEchoClient>(stream, device.options.get<LineEchoOptions>(), clock);
///   };
///   const devices::Codec line_echo = devices::register_codec(row);
/// @endcode
///
/// Built-in and registered codecs are reached the same way: `device.options.get<LineEchoOptions>()`,
/// `device.client.get<LineEchoClient>()` (`CodecOptions`, `DeviceClient`).
///
/// What a codec's boards are is the row's too, so the devices library names none: a codec on virtual rings
/// gives the image a board runs by default (`ring_board_image`) and reads a board's `"eeprom": {...}`
/// settings into its EEPROM bytes (`ring_board_settings`); one whose boards take a configuration file for
/// `tether flash --eeprom` parses it (`eeprom_file`). Elcano's do all three (`tether/elcano/node_settings.hpp`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "tether/core/session/request_table.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/json_reader.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/boot_detection.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/capture_framing.hpp"
#include "tether/transports/capture_replay.hpp"

namespace tether::devices {

/// Which virtual transport carries a codec: one simulated board (`"virtual"`) or a ring of them
/// (`"virtual_ring"`, whose host node sends what it does not consume on round the ring).
enum class VirtualBoards {
  single,  ///< `{"virtual": {...}}` only.
  ring,    ///< `{"virtual_ring": {...}}` only.
};

/// What a row's option parser gets.
struct OptionsContext {
  /// The device's `"options"` object, its keys already checked against `CodecRow::option_keys`; null when the
  /// device has none (the parser returns the defaults).
  const nlohmann::json* options = nullptr;
  /// JSON path of the options (`devices[1].options`), for the `ConfigError`s the parser throws.
  std::string path;
  /// The row's codec (one parser may serve two rows: proxy and proxy-compat).
  Codec codec{};
  /// The device's transport, already parsed (a serial transport's baud is the default of a codec's own).
  const TransportConfig* transport = nullptr;
  /// The folder relative file names in the options resolve against (`ParseOptions::base_dir`: the
  /// configuration file's folder for `load_config`); empty: the working directory.
  std::filesystem::path base_dir;

  /// A file named in the options (`"schema": "arm.proto"`): as given when absolute or when `base_dir` is
  /// empty, else relative to `base_dir`.
  std::filesystem::path resolve_path(const std::filesystem::path& file) const {
    return file.is_relative() && !base_dir.empty() ? (base_dir / file).lexically_normal() : file;
  }

  /// The options object to read (json_reader.hpp), or nothing when the device has none.
  std::optional<JsonObject> object() const {
    if (options == nullptr) return std::nullopt;
    return JsonObject(JsonNode{*options, path});
  }
};

/// What a row's ring-board parser gets: one board of a virtual ring whose `eeprom` is an object of settings
/// rather than bytes.
struct RingBoardContext {
  /// The settings object, with its path (`devices[0].transport.virtual_ring.boards[1].eeprom`).
  JsonNode settings;
  /// The board's place in the ring (0: the one the host writes to).
  std::size_t index = 0;
  /// The device's options, already parsed (a ring's settings may depend on them: Elcano's generation).
  const CodecOptions* options = nullptr;
};

/// An EEPROM configuration ready for `tether flash --eeprom`: a bootloader such as optiboot writes no
/// EEPROM, so the bytes travel in the image's flash and the image copies them into EEPROM at boot.
struct EepromUpload {
  std::vector<std::uint8_t> bytes;  ///< What goes into flash.
  std::uint32_t flash_address = 0;  ///< Where: the image's boot code looks for them there.
};

/// A file of one board's EEPROM configuration that a codec's boards take (`tether flash --eeprom FILE`).
struct EepromFileFormat {
  /// An image that reads it, for messages (`--eeprom needs an image below it, such as elcano-node`).
  std::string_view image;
  /// Its lines of `tether flash`'s usage text under `--eeprom FILE`, aligned like the others' and ending in
  /// a newline.
  std::string_view usage;
  /// The file's text into the bytes and where they go; throws `ConfigError` naming the key (an empty path:
  /// the file itself). Unset: the codec takes no such file.
  std::function<EepromUpload(std::string_view text)> parse;
};

/// Reads the call-timing keys a codec with calls takes: `attempt_timeout_ms`, `call_budget_ms` (both >= 1)
/// and `max_attempts` (1..255), into `timing` (what is absent keeps its value).
void read_call_timing(const JsonObject& object, session::CallTiming& timing);
/// Checks call timing built in code: every one of those values at least 1, else a `ConfigError` at
/// `options_path`'s key.
void check_call_timing(const std::string& options_path, const session::CallTiming& timing);

/// One codec: its names, options, transports and how a device speaking it is opened. Every function is
/// called on the thread that parses or opens; they report errors by throwing `ConfigError`.
struct CodecRow {
  /// The codec's value: a plugin's own constant (below 16); `register_codec` assigns one to a new row.
  Codec codec{};
  /// Its name in configurations (`"codec": "romi"`), in messages and on the command line (`--codec`).
  std::string_view name;
  /// What opens it, for messages and documentation: `romi::Client`.
  std::string_view client_name;
  /// The type of its client (`&typeid(romi::Client)`): `Rover::client<Client>` names the codecs whose client a
  /// device does not have. Null: not named.
  const std::type_info* client_type = nullptr;
  /// Keys allowed in the device's `"options"`; a key of another codec's only is named as such.
  std::vector<std::string_view> option_keys;
  /// Line speed of a serial transport that does not set one.
  std::uint32_t default_baud = 115200;
  /// The virtual transport that carries it.
  VirtualBoards virtual_boards = VirtualBoards::single;
  /// A ring's boards: the image of a board without `"firmware"` (`elcano-node`); empty: a board names its own.
  std::string_view ring_board_image;
  /// A ring board's `"eeprom": {...}` settings object into its initial EEPROM (from address 0, at most 1024
  /// bytes), called once the device's options are parsed; throws `ConfigError` at the settings' keys. Unset:
  /// a board's `eeprom` is bytes only.
  std::function<std::vector<std::uint8_t>(const RingBoardContext& board)> ring_board_settings;
  /// The EEPROM files its boards take (`tether flash --eeprom`: the first row that has one parses the file).
  EepromFileFormat eeprom_file;
  /// What its firmware does at boot (transports/boot_detection.hpp): an announcement to recognise or a probe
  /// to send, so a serial device that resets on open is ready as soon as it booted (`"boot": "detect"`, the
  /// default where this is `usable()`). Unset: its devices wait `boot_wait_ms` (`"fixed"`).
  transports::BootSignature boot;
  /// The options of a configuration's device (`OptionsContext::options` null: the defaults).
  std::function<CodecOptions(const OptionsContext& context)> parse_options;
  /// Checks options built in code (what parsing guarantees); throws `ConfigError` at `options_path`'s keys.
  /// Unset: nothing to check.
  std::function<void(const CodecOptions& options, const std::string& options_path)> validate;
  /// The client of `device` on its opened byte stream (which it owns from then on), its deadlines on
  /// `clock`: a virtual device's board time (rover.hpp, "Clocks of virtual devices"), null for hardware
  /// (the steady clock, every client's default).
  std::function<DeviceClient(std::shared_ptr<transports::ByteStream> stream, const DeviceConfig& device,
                             std::shared_ptr<client::LinkClock> clock)>
      open;
  /// Waits until the new client is ready for the application (proxy: handshake and inits), within the
  /// device's limits; throws `ConfigError` under `device_path` (`devices[1]`). Unset: ready when created.
  std::function<void(const DeviceClient& client, const DeviceConfig& device, const std::string& device_path)>
      await_ready;
  /// How a recording of its devices cuts the bytes into packets (transports/capture_framing.hpp,
  /// docs/captures.md): one framer per direction, whole frames as packets and what formed none as `unframed`
  /// ones. Unset: every read and write is one `unframed: no framing` packet.
  std::function<transports::CaptureFraming(const DeviceConfig& device)> capture_framing;
  /// The words its devices' capture interfaces add to `tether codec=... baud=... transport=...` (space-separated
  /// `key=value`, values through `transports::capture_word_value`): `generation=D`, `crc=on`. Unset: none.
  std::function<std::string(const DeviceConfig& device)> capture_words;
  /// How `tether replay --as-device` plays a recorded device of it to a live host
  /// (transports/capture_replay.hpp): which recorded request a host frame is, and the recorded answers with
  /// the live host's ids and CRCs. Unset: its captures cannot be played as a device.
  std::function<std::unique_ptr<transports::CaptureReplayer>(const DeviceConfig& device)> capture_replay;
};

/// The row of `codec`. Throws `std::out_of_range` for a value no row has.
const CodecRow& codec_row(Codec codec);
/// The row named `name` (`"proxy-compat"`), or null.
const CodecRow* find_codec(std::string_view name);
/// Every row: the built-in ones, then the registered ones in registration order.
std::vector<const CodecRow*> codec_rows();

/// Adds `row` to the table and returns its new `Codec` value (also stored in the row). Throws
/// `std::invalid_argument` when the name is empty or taken, or `parse_options` or `open` is unset. Meant for
/// start-up: rows are never removed, and a configuration parsed before cannot name the codec.
Codec register_codec(CodecRow row);

}  // namespace tether::devices
