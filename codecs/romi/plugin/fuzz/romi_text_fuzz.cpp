// Fuzz target of what `tether monitor` and `tether shell` make of what a Romi device says: frames and log lines
// through the monitor's decoder, the shell's answer lines (the answer array parsed from device bytes, as the client
// does) and log lines, each rendered as the text line and the JSON line. Input and invariants:
// tools/tether/text_fuzzing.hpp.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "romi_text.hpp"
#include "tether/romi/plugin.hpp"
#include "text_fuzzing.hpp"

using namespace tether;
using namespace tether::cli;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  if (fuzzes_monitor(selector)) {
    devices::DeviceConfig config;
    config.codec = romi::kCodec;
    config.options = romi::DeviceOptions();
    check_monitor_decoding(config, data, size);
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
    check_shell_line("answer", romi_answer_line(body, response));
    return 0;
  }
  check_shell_line("event", romi_log_line(input.ConsumeRemainingBytesAsString()));
  return 0;
}
