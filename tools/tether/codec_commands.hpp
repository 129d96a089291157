// The `tether` command's columns of the codec table (devices/codecs.hpp): for each codec, how the device
// options build it from the command line, its counters, its shell (what a typed line does, what its events
// print) and its monitor decoder. Subcommands look a codec up here instead of switching on it. A codec's rows
// come from its plugin (`tether_codec_plugin(... COMMANDS ...)` in codecs/<codec>/plugin/), or from a program
// that registers a codec at start-up (`register_codec`); docs/codecs.md, "Adding a codec".
#pragma once

#include <nlohmann/json.hpp>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/core/counters.hpp"
#include "tether/devices/codecs.hpp"

namespace tether::cli {

struct DeviceOptions;  // device_options.hpp

/// How a shell prints, from any thread: text lines or JSON lines of a "type".
struct ShellPrinter {
  bool json = false;  ///< JSON lines instead of text

  void print(std::string_view type, const ShellLine& line) const;
  void answer(const ShellLine& line) const { print("answer", line); }
  void event(const ShellLine& line) const { print("event", line); }
  void error(const std::string& text) const { print("error", {"error: " + text, {{"message", text}}}); }
  void info(const std::string& type, const std::string& text, const nlohmann::ordered_json& object) const {
    print(type, {text, object});
  }
};

/// What a codec's shell gets: where to print and whom to tell that the link failed (the shell then ends
/// with exit status 2).
struct ShellContext {
  ShellPrinter printer;
  std::function<void()> link_failed;
  const DeviceOptions* options = nullptr;  ///< the command line's device options
};

/// One device's shell, for its codec: created as soon as the client exists (its event handlers see
/// everything from the first byte), used by the shell's main thread.
class ShellSession {
 public:
  virtual ~ShellSession() = default;
  /// Printed after the "connected to ..." line (e.g. what a lone virtual board does).
  virtual void greet() {}
  /// Sends the typed line (not empty, not a `:` command) and prints what became of it.
  virtual void send(const std::string& line) = 0;
  /// Runs a shell command of this codec (`:capture TYPES`); false when `words[0]` is none of its own.
  virtual bool command(const std::vector<std::string>& /*words*/) { return false; }
  /// End of input: waits, bounded (and until `stop`), for what the lines sent are still owed.
  virtual void finish(const std::atomic<bool>& /*stop*/) {}
};

/// A device option of the command line that only some codecs take (`--generation B|D`): parsed with the
/// other device options, kept as given (`DeviceOptions::codec_flags`) and read by the row's
/// `default_options`. Refused with `--config` (the configuration sets it) and for a codec without it.
struct CodecFlag {
  std::string_view name;   ///< `--generation` (it takes a value)
  std::string_view usage;  ///< its lines of the usage text, aligned like the others' (`    --generation B|D  ...\n`)
  /// What `value` should have been (`B or D`: "--generation needs B or D, got 'x'"), or nothing when it is fine.
  std::function<std::optional<std::string>(std::string_view value)> check;
};

/// How `tether replay --against-virtual` compares one device->host frame of the codec (a recorded one or one the
/// virtual board sent): what differs between two runs of the same firmware by nature (a session id chosen at
/// boot, a periodic report whose count depends on how long the run was) is left out or compared without it,
/// under a rule the report names and counts.
struct ReplayFrameView {
  /// Left out of the comparison (counted under `rule`).
  bool ignored = false;
  /// Compared instead of the frame's bytes when not empty (the frame with what differs by nature taken out).
  std::string key;
  /// Why, for the report (`info: sent every 5 s, how many depends on the run's length`); empty when the frame
  /// is compared as it is.
  std::string rule;
};

/// The `tether` command's row of a codec.
struct CodecCommands {
  /// The codec's name: its devices row's (`romi`).
  std::string_view name;
  /// `--virtual IMAGE`: images whose file name starts with one of these speak it (the longest prefix wins;
  /// no match: the default codec).
  std::vector<std::string_view> image_prefixes;
  /// An image of its firmware in the firmware folder, named in the `--virtual` usage (`romi-test`; empty:
  /// none).
  std::string_view example_image;
  /// The codec of a `--port` without `--codec` and of a `--virtual` image no prefix matches (one row has it:
  /// romi's).
  bool is_default = false;
  /// The device options only it takes, in the usage text under `<name> only, with --port or --virtual:`.
  std::vector<CodecFlag> flags;
  /// Printed after them: what else a person should know of its devices on the command line.
  std::string_view usage_note;
  /// The options of a device named by `--port` or `--virtual` (`baud`: the line speed). May throw
  /// `devices::ConfigError` (a codec flag's file that does not read): the command's usage error.
  std::function<devices::CodecOptions(std::uint32_t baud, const DeviceOptions& options)> default_options;
  /// `--virtual`: the transport of a lone board running `firmware` (and what it changes in the options).
  /// Unset: one virtual board.
  std::function<void(const std::filesystem::path& firmware, const DeviceOptions& options,
                     devices::DeviceConfig& config)>
      lone_virtual_board;
  /// Shown while the device gets ready after its client exists (`waiting for the proxy session...`).
  std::string_view readying;
  /// The client's counters, beside the link's: `{"link": {...}, "proxy": {...}}`.
  std::function<nlohmann::ordered_json(const devices::DeviceClient& client)> counters;
  /// `:help` of its shell.
  std::function<std::string(const devices::DeviceConfig& config)> shell_help;
  /// Its shell on `client` (event handlers attached at once). Unset: `tether shell` refuses the codec.
  std::function<std::unique_ptr<ShellSession>(const devices::DeviceClient& client, const devices::DeviceConfig& config,
                                              const ShellContext& context)>
      open_shell;
  /// `tether monitor`'s decoder (and, for a ring, the host's node). Unset: monitor refuses the codec.
  std::function<std::unique_ptr<MonitorDecoder>(const devices::DeviceConfig& config, const DecoderRole& role,
                                                Millis now)>
      monitor_decoder;
  /// `monitor --keepalive` applies (proxy primary mode).
  bool monitor_keepalive = false;
  /// `tether replay --against-virtual`: how a device->host frame (its bytes and what the monitor decoder made of
  /// them) is compared. Unset: every frame is compared byte for byte.
  std::function<ReplayFrameView(std::span<const std::uint8_t> frame, const std::vector<MonitorRecord>& decoded)>
      replay_frame_view;
  /// What `replay_frame_view` leaves out, for the usage text and the report (`proxy: ...`); empty: nothing.
  std::string_view replay_rules;
  /// `tether stats`' usage: what runs on the link meanwhile (after the codec's name; lines after the first
  /// indented by 16 spaces, each ending in a newline).
  std::string_view stats_activity;
  /// `tether stats`: the probe sent every interval unless `--passive` (unset: the codec takes no probe).
  std::string_view default_probe;
  /// `tether stats --probe`'s usage for the codec (`the command sent every interval (default '?')`); set
  /// with `check_probe`.
  std::string_view probe_usage;
  /// Why `probe` cannot be sent (nothing: it can).
  std::function<std::optional<std::string>(const std::string& probe)> check_probe;
  /// Sends `probe` once; true when the device answered.
  std::function<bool(const devices::DeviceClient& client, const std::string& probe)> send_probe;
};

/// The shell commands every shell takes, for the end of a codec's `:help`.
inline constexpr const char* kShellCommands =
    "Shell commands: :help, :stats (the session's counters), :quit (or Ctrl-D).";

namespace detail {
/// The rows of every codec plugin that has them (`tether_codec_plugin(... COMMANDS ...)`; generated from
/// plugin_commands.cpp.in).
std::vector<CodecCommands> plugin_command_rows();
}  // namespace detail

/// The row of `codec`, or null when the `tether` command has none (a codec registered with the devices
/// library only).
const CodecCommands* codec_commands(devices::Codec codec);

/// Registers a codec with the devices library (`devices::register_codec`) and with the command; for start-up,
/// before a subcommand runs. Returns its value. Throws `std::invalid_argument` like `devices::register_codec`.
devices::Codec register_codec(devices::CodecRow device, CodecCommands commands);

/// The codec named on the command line (`--codec`).
std::optional<devices::Codec> parse_codec(std::string_view text);
/// The codecs the command knows: `romi, proxy, proxy-compat or elcano`.
std::string codec_choices();
/// The codec whose row `is_default` (else the first row's).
devices::Codec default_codec();
/// The row of the codec a `--virtual` image's file name says (the longest image prefix it starts with:
/// `romi-blink` is romi's), or null when no codec claims the name.
const devices::CodecRow* codec_row_of_image(const std::filesystem::path& firmware);
/// The codec of a `--virtual` image (by its file name; the default codec when no codec claims it).
devices::Codec codec_of_image(const std::filesystem::path& firmware);

/// `{"frames_ok": 1, ...}` of every link counter.
nlohmann::ordered_json link_counters_json(const LinkCounters& counters);

}  // namespace tether::cli
