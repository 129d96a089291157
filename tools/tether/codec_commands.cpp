// The `tether` command's table of codec rows (see codec_commands.hpp); the rows are the codec plugins'.
#include "codec_commands.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <variant>

#include "cli_support.hpp"
#include "device_options.hpp"
#include "tether/devices/codec_rows.hpp"

namespace tether::cli {

void ShellPrinter::print(std::string_view type, const ShellLine& line) const {
  out().line(shell_output(type, line, json));
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

namespace {

devices::CodecRows<CodecCommands>& table() {
  static devices::CodecRows<CodecCommands> instance(detail::plugin_command_rows());
  return instance;
}

}  // namespace

const CodecCommands* codec_commands(devices::Codec codec) { return table().find(devices::to_string(codec)); }

devices::Codec register_codec(devices::CodecRow device, CodecCommands commands) {
  commands.name = device.name;
  const devices::Codec codec = devices::register_codec(std::move(device));
  table().add(std::move(commands), "cli::register_codec");
  return codec;
}

std::optional<devices::Codec> parse_codec(std::string_view text) {
  if (const devices::CodecRow* row = devices::find_codec(text); row != nullptr && codec_commands(row->codec)) {
    return row->codec;
  }
  return std::nullopt;
}

std::string codec_choices() {
  std::vector<std::string_view> names;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    if (codec_commands(row->codec) != nullptr) names.push_back(row->name);
  }
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) text += i + 1 == names.size() ? " or " : ", ";
    text += names[i];
  }
  return text;
}

devices::Codec default_codec() {
  const std::vector<const devices::CodecRow*> rows = devices::codec_rows();
  for (const devices::CodecRow* row : rows) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands != nullptr && commands->is_default) return row->codec;
  }
  return rows.empty() ? devices::Codec{} : rows.front()->codec;
}

const devices::CodecRow* codec_row_of_image(const std::filesystem::path& firmware) {
  const std::string stem = firmware.stem().string();
  const devices::CodecRow* best = nullptr;
  std::size_t longest = 0;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr) continue;
    for (const std::string_view prefix : commands->image_prefixes) {
      if (prefix.size() > longest && stem.starts_with(prefix)) {
        longest = prefix.size();
        best = row;
      }
    }
  }
  return best;
}

devices::Codec codec_of_image(const std::filesystem::path& firmware) {
  const devices::CodecRow* row = codec_row_of_image(firmware);
  return row != nullptr ? row->codec : default_codec();
}

std::unique_ptr<MonitorDecoder> make_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                     Millis now) {
  const CodecCommands* commands = codec_commands(config.codec);
  if (commands == nullptr || !commands->monitor_decoder) return nullptr;
  return commands->monitor_decoder(config, role, now);
}

}  // namespace tether::cli
