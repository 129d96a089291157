// Fuzz target of what `tether monitor` and `tether shell` make of what an Elcano ring says: messages through the monitor's decoders (the host's ring
// node, which captures and forwards, and a tap's plain reader), ring events and captured messages as shell
// lines (fields from the bytes), each rendered as the text line and the JSON line.
// Input: byte 0 picks the path: bit 0 clear, the monitor's decoding (the other bits: the decoder's role; bit 6: generation D; bits 4..7: the
// capture set),
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
#include "elcano_text.hpp"
#include "tether/elcano/plugin.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

void render(std::string_view type, const ShellLine& line) {
  TETHER_FUZZ_CHECK(shell_output(type, line, false) == line.text);
  const std::string json = shell_output(type, line, true);
  TETHER_FUZZ_CHECK(json.rfind("{\"type\":", 0) == 0);
}

elcano::Message ring_message(FuzzedDataProvider& input) {
  elcano::Message message;
  static constexpr elcano::Type kTypes[] = {elcano::Type::drive, elcano::Type::sensor, elcano::Type::goal,
                                            elcano::Type::segment};
  message.type = kTypes[input.ConsumeIntegral<std::uint8_t>() % 4];
  message.number = input.ConsumeIntegral<std::int32_t>();
  message.speed = input.ConsumeIntegral<std::int32_t>();
  message.angle = input.ConsumeIntegral<std::int32_t>();
  message.obstacle = input.ConsumeIntegral<std::int32_t>();
  message.bearing = input.ConsumeIntegral<std::int32_t>();
  message.probability = input.ConsumeIntegral<std::int32_t>();
  message.east = input.ConsumeIntegral<std::int32_t>();
  message.north = input.ConsumeIntegral<std::int32_t>();
  return message;
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
  // A ring node forwards at most what it received.
  TETHER_FUZZ_CHECK(output <= 2 * size + 64 * (size / 1000 + 1));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  if ((selector & 0x01) == 0) {
    devices::DeviceConfig config;
    config.codec = elcano::kCodec;
    elcano::DeviceOptions options;
    options.generation = (selector & 0x40) != 0 ? elcano::Generation::d : elcano::Generation::b;
    options.capture = elcano::TypeSet::from_bits(static_cast<std::uint8_t>(selector >> 4));
    config.options = options;
    decode(config, selector, data, size);
    return 0;
  }
  FuzzedDataProvider input(data + 1, size - 1);
  if ((selector & 0x02) == 0) {
    const auto kind = input.ConsumeIntegral<std::uint8_t>() % 5;
    const auto error = static_cast<elcano::Error>(input.ConsumeIntegral<std::uint8_t>() % 10);
    const elcano::Message message = ring_message(input);
    const elcano::error_code link_error(input.ConsumeIntegral<int>(), boost::system::generic_category());
    elcano::Event event = elcano::events::LinkFailed{link_error};
    if (kind == 0) event = elcano::events::Undeliverable{message, false};
    if (kind == 1) event = elcano::events::InputDropped{error};
    if (kind == 2) event = elcano::events::ForwardDropped{message};
    if (kind == 3) event = elcano::events::ReceiveOverflow{message};
    const auto generation = input.ConsumeBool() ? elcano::Generation::d : elcano::Generation::b;
    render("event", ring_event_line(event, generation));
    return 0;
  }
  const elcano::Message message = ring_message(input);
  render("event", captured_line(message, input.ConsumeBool() ? elcano::Generation::d : elcano::Generation::b));
  return 0;
}
