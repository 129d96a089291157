// Fuzz target of what `tether monitor` and `tether shell` make of what a Romi device says: frames and log lines through the monitor's decoder, the shell's
// answer lines (the answer array parsed from device bytes, as the client does) and log lines, each rendered
// as the text line and the JSON line.
// Input: byte 0 picks the path: bit 0 clear, the monitor's decoding (the other bits: the decoder's role),
// the rest being the byte stream, one millisecond per byte; bit 0 set, a shell line (bits 1..: which one), the
// rest filling its values (FuzzedDataProvider: numbers, then text).
// Invariants: nothing throws (an exception would end the monitor or the shell's I/O thread), no sanitizer
// finding, every record has a kind and every JSON line its type, the output a decoder asks to send stays
// bounded.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "romi_text.hpp"
#include "tether/romi/plugin.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

void render(std::string_view type, const ShellLine& line) {
  TETHER_FUZZ_CHECK(shell_output(type, line, false) == line.text);
  const std::string json = shell_output(type, line, true);
  TETHER_FUZZ_CHECK(json.rfind("{\"type\":", 0) == 0);
}

// The monitor's decoding of `data` (one millisecond per byte) for `config` in the role byte 0 gives.
void decode(const devices::DeviceConfig& config, std::uint8_t selector, const uint8_t* data, size_t size) {
  DecoderRole role;
  role.direction = (selector & 0x04) != 0 ? Direction::host_to_device : Direction::device_to_host;
  role.ring_node = (selector & 0x08) == 0;
  role.keepalive = (selector & 0x80) != 0;
  const auto decoder = make_monitor_decoder(config, role, 0);
  TETHER_FUZZ_CHECK(decoder != nullptr);
  std::vector<MonitorRecord> records;
  std::size_t output = 0;
  for (size_t i = 1; i < size; ++i) {
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
  // The Romi decoder sends nothing; a bound all the same, as for every codec.
  TETHER_FUZZ_CHECK(output <= 2 * size + 64 * (size / 1000 + 1));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  if ((selector & 0x01) == 0) {
    devices::DeviceConfig config;
    config.codec = romi::kCodec;
    config.options = romi::DeviceOptions();
    decode(config, selector, data, size);
    return 0;
  }
  FuzzedDataProvider input(data + 1, size - 1);
  if ((selector & 0x02) == 0) {  // a romi answer as the client builds it from the frame's payload
    romi::RomiResponse response;
    response.code = input.ConsumeIntegral<std::int16_t>();
    response.id = input.ConsumeIntegral<std::uint8_t>();
    response.attempts = input.ConsumeIntegral<std::uint8_t>();
    response.answered = input.ConsumeBool();
    const std::string body = input.ConsumeRemainingBytesAsString();
    auto values = nlohmann::json::parse(body.begin(), body.end(), nullptr, false);
    if (!values.is_discarded()) response.values = std::move(values);
    response.message = body;
    render("answer", romi_answer_line(body, response));
    return 0;
  }
  render("event", romi_log_line(input.ConsumeRemainingBytesAsString()));
  return 0;
}
