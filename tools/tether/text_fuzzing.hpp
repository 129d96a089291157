// What every codec's text fuzz target (codecs/<codec>/plugin/fuzz/<codec>_text_fuzz.cpp) checks of the
// command's output paths: a monitor decoder fed random bytes, and shell lines built from random values.
// The input's byte 0 says which: bit 0 clear, the monitor's decoding (bits 2, 3 and 7: the decoder's role;
// the codec may read the others for its options), the rest being the byte stream, one millisecond per byte;
// bit 0 set, a shell line (the codec's bits 1..), the rest filling its values.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace tether::cli {

/// True when byte 0 picks the monitor's decoding.
inline bool fuzzes_monitor(std::uint8_t selector) { return (selector & 0x01) == 0; }

/// `line` as the shell prints it, both forms: the text is the line's, the JSON line has its type.
inline void check_shell_line(std::string_view type, const ShellLine& line) {
  TETHER_FUZZ_CHECK(shell_output(type, line, false) == line.text);
  const std::string json = shell_output(type, line, true);
  TETHER_FUZZ_CHECK(json.rfind("{\"type\":", 0) == 0);
}

/// The monitor's decoding of `data[1..size)` (one millisecond per byte) for `config`, in the role byte 0
/// gives: nothing throws, every record has a kind and renders, the output a decoder asks to send stays
/// bounded (what it received, plus a keepalive ping a second).
inline void check_monitor_decoding(const devices::DeviceConfig& config, const std::uint8_t* data, std::size_t size) {
  const std::uint8_t selector = data[0];
  DecoderRole role;
  role.direction = (selector & 0x04) != 0 ? Direction::host_to_device : Direction::device_to_host;
  role.ring_node = (selector & 0x08) == 0;
  role.keepalive = (selector & 0x80) != 0;
  const auto decoder = make_monitor_decoder(config, role, 0);
  TETHER_FUZZ_CHECK(decoder != nullptr);
  std::vector<MonitorRecord> records;
  std::size_t output = 0;
  for (std::size_t i = 1; i < size; ++i) {
    const auto now = static_cast<Millis>(i);
    decoder->feed(data[i], now, records);
    decoder->poll(now, records);
    output += decoder->output(now).size();
    for (const MonitorRecord& record : records) {
      TETHER_FUZZ_CHECK(!record.kind.empty());
      TETHER_FUZZ_CHECK(!record_text(record).empty());
      TETHER_FUZZ_CHECK(!dump(record_json(record)).empty());
    }
    records.clear();
  }
  TETHER_FUZZ_CHECK(output <= 2 * size + 64 * (size / 1000 + 1));
}

}  // namespace tether::cli
