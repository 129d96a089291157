// Fuzz target of what `tether monitor` and `tether shell` make of what an Elcano ring says: messages through the
// monitor's decoders (the host's ring node, which captures and forwards, and a tap's plain reader), ring events and
// captured messages as shell lines (fields from the bytes), each rendered as the text line and the JSON line. Input
// and invariants: tools/tether/text_fuzzing.hpp (byte 0, bit 6: generation D; bits 4..7: the capture set).
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "elcano_text.hpp"
#include "tether/elcano/plugin.hpp"
#include "text_fuzzing.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  if (fuzzes_monitor(selector)) {
    devices::DeviceConfig config;
    config.codec = elcano::kCodec;
    elcano::DeviceOptions options;
    options.generation = (selector & 0x40) != 0 ? elcano::Generation::d : elcano::Generation::b;
    options.capture = elcano::TypeSet::from_bits(static_cast<std::uint8_t>(selector >> 4));
    config.options = options;
    check_monitor_decoding(config, data, size);
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
    check_shell_line("event", ring_event_line(event, generation));
    return 0;
  }
  const elcano::Message message = ring_message(input);
  check_shell_line("event", captured_line(message, input.ConsumeBool() ? elcano::Generation::d : elcano::Generation::b));
  return 0;
}
