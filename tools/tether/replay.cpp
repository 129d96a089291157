// `tether replay FILE`: prints a capture (docs/captures.md) as `tether monitor --tap` prints a live session:
// each device link's bytes, each direction through its codec's monitor decoder (the interface's `codec=`
// word, its options from the other words: `generation=D`, `schema=arm.proto`), with the recorded times.
//
// Output contract: one line per record, `<time> [<device>] <direction> <kind> <detail>` (the device named
// when the capture has several links; time in ms since the first packet, or ISO 8601 UTC with --utc), link
// events as `link <event>`; with --json one object per line. Exit status 0; 2 for usage errors and a file
// that is not a readable Tether capture (the reader's message names the offset). `--against-virtual IMAGE`
// compares a virtual board's answers with the recorded ones instead (replay_against_virtual.hpp).
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "monitor_decoding.hpp"
#include "replay_against_virtual.hpp"
#include "replay_as_device.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/transports/pcapng.hpp"

namespace tether::cli {

namespace {

const CommandText& replay_command() {
  static const CommandText text(
      "replay",
      "usage: tether replay FILE [--device NAME] [--utc] [--json]\n"
      "       tether replay FILE [--device NAME] --against-virtual IMAGE [--settle MS] [--json]\n"
      "       tether replay FILE [--device NAME] --as-device [--link PATH] [--loop] [--json]\n"
      "\n"
      "Prints what a capture recorded (a pcapng file written by --record, monitor --write or a configuration's\n"
      "\"record\"; docs/captures.md) as `tether monitor --tap` prints a session: every frame, log line,\n"
      "message and error of each device link, both directions, decoded by the codec the capture names, with\n"
      "the recorded times (milliseconds since the first packet).\n"
      "\n"
      "  --device NAME  only the link of device NAME (an interface of the capture)\n"
      "  --utc          ISO 8601 UTC wall-clock timestamps (as recorded) instead of milliseconds\n"
      "  --json         one JSON object per line: {\"t_ms\":12.345,\"device\":\"arm\",\"direction\":\"host->device\",\n"
      "                 \"kind\":\"frame\",...} (\"time\" with --utc)\n"
      "\n"
      "--against-virtual IMAGE: boots IMAGE (an image name such as romi-test, or a path to an .elf, as --virtual\n"
      "takes it) on a virtual Uno, sends it the host->device bytes of the link (--device NAME; not needed when\n"
      "the capture has one) at their recorded offsets from the link's first one, on the board's clock from its\n"
      "boot (faster than real time when it can), and compares what it answers with what was recorded: both cut\n"
      "into frames by the codec's framing, aligned, each difference printed with its time and the frame as\n"
      "replay prints it (changed: the recorded frame, then the new one as `now`; recorded-only; new-only),\n"
      "then `same: N frames the same, 0 differ` or `different: ...`. A codec on rings runs IMAGE as --virtual\n"
      "does: a ring of one board. Frames that differ between two runs by nature are left out or compared in\n"
      "part by the codec's rules and counted (`ignored:` lines):\n" +
          against_virtual_rules_usage() +
          "  --settle MS    board time run past the link's last recorded packet (default 500)\n"
      "  --json         one object per difference ({\"difference\":\"changed\",\"t_ms\":..,\"recorded\":{..},\n"
      "                 \"new\":{..}}), per rule, and {\"summary\":{\"result\":\"same\",\"same\":N,\"differ\":M,..}}\n"
      "\n"
      "--as-device plays the recorded device of link NAME (needed when the capture has several) on a\n"
      "pseudo-terminal, so host code can be tested offline against a recorded session: prints `PTY <path>`\n"
      "({\"pty\":...,\"device\":...} with --json); when the host sends the next recorded request (ids and\n"
      "CRCs aside), the device frames recorded after it go out with their recorded delays, rewritten for the\n"
      "host (its ids, the CRCs over them); frames the device sent on its own (log lines, state messages) go\n"
      "at their recorded times after the request they followed. A request that does not match the\n"
      "recording is a line on stderr (expected, got) and gets the device's answer to an unknown request.\n"
      "Ends at the end of the recording (once the host has read it all, or left it unread for 2 s, and 0.5 s\n"
      "passed without a frame), or on SIGINT/SIGTERM.\n"
      "  --link PATH    also make PATH a symlink to the pty (removed at exit)\n"
      "  --loop         start the recording again as soon as its last frame went out, until a signal\n"
      "\n"
      "Exit status: 0 the capture was printed (--against-virtual: the board answered as recorded;\n"
      "--as-device: played to its end, or stopped by a signal); 1 the board's answers differ; 2 usage errors,\n"
      "a file that is not a Tether capture, is truncated or corrupt (the message names the offset), names a\n"
      "codec or schema this tether cannot decode or play, has no such link, or an image that is missing or of\n"
      "another codec.\n");
  return text;
}

std::string utc_text(std::uint64_t microseconds) {
  const std::time_t seconds = static_cast<std::time_t>(microseconds / 1000000);
  std::tm parts{};
  gmtime_r(&seconds, &parts);
  char buffer[64];
  const std::size_t length = std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%S", &parts);
  std::snprintf(buffer + length, sizeof buffer - length, ".%03dZ", static_cast<int>((microseconds / 1000) % 1000));
  return buffer;
}

// The device configuration a monitor decoder needs, from an interface's description: its codec's row and
// the options its codec flags would give (`generation=D` as `--generation D`).
std::optional<devices::DeviceConfig> device_of(const transports::CaptureInterface& interface, std::string& error) {
  const std::string codec = interface.word("codec");
  const devices::CodecRow* row = devices::find_codec(codec);
  const CodecCommands* commands = row != nullptr ? codec_commands(row->codec) : nullptr;
  if (commands == nullptr || !commands->monitor_decoder) {
    error = codec.empty() ? "its description names no codec (not a Tether capture?)"
                          : "codec '" + codec + "' is not one this tether can decode";
    return std::nullopt;
  }
  DeviceOptions options;
  for (const auto& [key, value] : interface.words()) {
    const std::string flag = "--" + key;
    for (const CodecFlag& each : commands->flags) {
      if (each.name != flag) continue;
      if (const auto expected = each.check(value)) {
        error = key + "=" + value + ": expected " + *expected;
        return std::nullopt;
      }
      options.codec_flags.emplace_back(flag, value);
    }
  }
  devices::DeviceConfig device;
  device.name = interface.name;
  device.codec = row->codec;
  const std::string baud = interface.word("baud");
  const std::uint32_t speed = baud.empty() || baud == "-" ? row->default_baud
                                                          : parse_number(baud, 1, 4000000).value_or(row->default_baud);
  try {
    device.options = commands->default_options(speed, options);
  } catch (const devices::ConfigError& failure) {
    error = failure.what();
    return std::nullopt;
  }
  return device;
}

// The one link `--against-virtual` and `--as-device` play (`--device NAME`'s, or the capture's only one) and
// its device; nothing, with the message in `error`, when there is no such link or it cannot be decoded.
std::optional<std::pair<std::size_t, devices::DeviceConfig>> one_link(const transports::Capture& capture,
                                                                      const std::optional<std::string>& only,
                                                                      const std::string& file, std::string& error) {
  devices::NameList names;
  for (const auto& interface : capture.interfaces) names.add(interface.name);
  std::size_t link = 0;
  if (only) {
    const auto named = std::find_if(capture.interfaces.begin(), capture.interfaces.end(),
                                    [&](const auto& interface) { return interface.name == *only; });
    if (named == capture.interfaces.end()) {
      error = file + ": no device '" + printable(*only) + "' (devices: " + names.text() + ")";
      return std::nullopt;
    }
    link = static_cast<std::size_t>(named - capture.interfaces.begin());
  } else if (capture.interfaces.size() != 1) {
    error = file + (capture.interfaces.empty() ? ": no device links in the capture"
                                               : ": " + std::to_string(capture.interfaces.size()) + " device links (" +
                                                     names.text() + "): name one with --device");
    return std::nullopt;
  }
  std::string why;
  std::optional<devices::DeviceConfig> device = device_of(capture.interfaces[link], why);
  if (!device) {
    error = file + ": interface " + std::to_string(link) + " (" + printable(capture.interfaces[link].name) + "): " + why;
    return std::nullopt;
  }
  return std::pair{link, std::move(*device)};
}

}  // namespace

int run_replay(int argc, char** argv) {
  std::string file;
  std::optional<std::string> only;
  bool utc = false;
  bool json = false;
  std::optional<std::string> against_virtual;
  std::optional<std::uint32_t> settle_ms;
  bool as_device = false;
  AsDeviceOptions play;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--utc") {
      utc = true;
    } else if (argument == "--json") {
      json = true;
    } else if (argument == "--as-device") {
      as_device = true;
    } else if (argument == "--loop") {
      play.loop = true;
    } else if (argument == "--link") {
      if (i + 1 >= argc || *argv[i + 1] == '\0') return replay_command().usage_error("--link needs a path");
      play.link = argv[++i];
    } else if (argument == "--device") {
      if (i + 1 >= argc || *argv[i + 1] == '\0') return replay_command().usage_error("--device needs a device name");
      only = argv[++i];
    } else if (argument == "--against-virtual") {
      if (i + 1 >= argc || *argv[i + 1] == '\0') return replay_command().usage_error("--against-virtual needs an image");
      against_virtual = argv[++i];
    } else if (argument == "--settle") {
      const auto value = i + 1 < argc ? parse_number(argv[i + 1], 0, 3600000) : std::nullopt;
      if (!value) return replay_command().usage_error("--settle needs milliseconds (0..3600000)");
      settle_ms = *value;
      ++i;
    } else if (!argument.starts_with("-") && file.empty()) {
      file = argument;
    } else {
      return replay_command().unexpected_argument(argument);
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, replay_command(), own)) return *status;
  if (file.empty()) return replay_command().usage_error("no capture file given");
  if (against_virtual && utc) return replay_command().usage_error("--utc does not apply to --against-virtual");
  if (settle_ms && !against_virtual) return replay_command().usage_error("--settle applies to --against-virtual only");
  if (!as_device && (play.loop || play.link)) {
    return replay_command().usage_error(std::string(play.loop ? "--loop" : "--link") + " applies to --as-device only");
  }
  if (as_device && utc) return replay_command().usage_error("--utc does not apply to --as-device");
  if (as_device && against_virtual) {
    return replay_command().usage_error("--as-device and --against-virtual exclude each other");
  }

  boost::system::error_code error;
  std::string message;
  const std::optional<transports::Capture> capture = transports::read_capture(file, error, message);
  if (!capture) return replay_command().fail(message);
  if (against_virtual || as_device) {
    std::string why;
    std::optional<std::pair<std::size_t, devices::DeviceConfig>> chosen = one_link(*capture, only, file, why);
    if (!chosen) return replay_command().fail(why);
    if (against_virtual) {
      return replay_against_virtual(
          {file, &*capture, chosen->first, std::move(chosen->second), *against_virtual, json, settle_ms.value_or(500)},
          replay_command());
    }
    play.file = file;
    play.json = json;
    return replay_as_device(*capture, static_cast<std::uint32_t>(chosen->first), chosen->second, play);
  }

  // One decoder per link and direction, made when the link first has bytes.
  struct Link {
    devices::DeviceConfig device;
    std::unique_ptr<MonitorDecoder> decoders[2];
  };
  std::vector<std::optional<Link>> links(capture->interfaces.size());
  bool found = !only;
  for (std::size_t i = 0; i < capture->interfaces.size(); ++i) {
    const transports::CaptureInterface& interface = capture->interfaces[i];
    if (only && interface.name != *only) continue;
    found = true;
    std::string why;
    std::optional<devices::DeviceConfig> device = device_of(interface, why);
    if (!device) {
      return replay_command().fail(file + ": interface " + std::to_string(i) + " (" + printable(interface.name) +
                                 "): " + why);
    }
    links[i] = Link{std::move(*device), {}};
  }
  if (!found) {
    devices::NameList names;
    for (const auto& interface : capture->interfaces) names.add(interface.name);
    return replay_command().fail(file + ": no device '" + *only + "' (devices: " + names.text() + ")");
  }
  const bool named = capture->interfaces.size() > 1 && !only;
  const std::uint64_t first = capture->packets.empty() ? 0 : capture->packets.front().timestamp_us;

  std::vector<MonitorRecord> records;
  for (const transports::CapturePacket& packet : capture->packets) {
    if (packet.interface >= links.size() || !links[packet.interface]) continue;
    Link& link = *links[packet.interface];
    const std::uint64_t since = packet.timestamp_us >= first ? packet.timestamp_us - first : 0;
    const auto print = [&](const MonitorRecord& record, std::optional<Direction> direction) {
      if (json) {
        nlohmann::ordered_json object;
        if (utc) {
          object["time"] = utc_text(packet.timestamp_us);
        } else {
          object["t_ms"] = static_cast<double>(since) / 1000.0;
        }
        if (named) object["device"] = link.device.name;
        if (direction) object["direction"] = to_string(*direction);
        const nlohmann::ordered_json fields = record_json(record);
        for (const auto& [key, value] : fields.items()) object[key] = value;
        out().line(dump(object));
        return;
      }
      char stamp[32];
      std::snprintf(stamp, sizeof stamp, "%.3f", static_cast<double>(since) / 1000.0);
      out().line((utc ? utc_text(packet.timestamp_us) : std::string(stamp)) + " " +
                 (named ? printable(link.device.name) + " " : std::string()) +
                 (direction ? std::string(to_string(*direction)) + " " : std::string()) + record_text(record));
    };
    if (packet.link_event()) {
      const std::string event = packet.comment.substr(6);
      print(MonitorRecord{"link", printable(event), {{"event", event}}, false}, std::nullopt);
      continue;
    }
    if (packet.direction == transports::CaptureDirection::unknown) continue;
    const Direction direction = packet.direction == transports::CaptureDirection::inbound ? Direction::device_to_host
                                                                                          : Direction::host_to_device;
    auto& decoder = link.decoders[direction == Direction::device_to_host ? 0 : 1];
    const Millis now = static_cast<Millis>(since / 1000);
    if (!decoder) {
      DecoderRole role;
      role.direction = direction;
      role.ring_node = false;  // only decode, as a tap does
      decoder = make_monitor_decoder(link.device, role, now);
    }
    for (const std::uint8_t byte : packet.data) decoder->feed(byte, now, records);
    for (const MonitorRecord& record : records) print(record, direction);
    records.clear();
  }
  out().flush();
  if (const std::string failure = out().write_failure(); !failure.empty()) return replay_command().fail(failure);
  return 0;
}

}  // namespace tether::cli
