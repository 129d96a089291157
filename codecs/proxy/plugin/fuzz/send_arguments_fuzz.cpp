// Fuzz target of `tether send`'s MESSAGE FIELD=VALUE parser (parse_proxy_command, both schemas).
// Input: byte 0 picks the mode (even: primary, odd: compat), the rest is the command line, one word per
// space-separated piece (empty pieces kept: a shell can pass empty arguments).
// Invariants: nothing throws, no sanitizer finding; a failure names its culprit (a non-empty error); a
// success sets exactly the message of its mode's schema, with one `data` alternative, and parsing it again
// from the same words gives the same bytes (no hidden state).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "proxy_text.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

std::string serialized(const ProxyCommand& command) {
  return std::visit([](const auto& message) { return message.SerializeAsString(); }, command.message);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const proxy::Mode mode = (data[0] & 1u) == 0 ? proxy::Mode::primary : proxy::Mode::compat;
  std::vector<std::string> words(1);
  for (size_t i = 1; i < size; ++i) {
    if (data[i] == ' ') {
      words.emplace_back();
    } else {
      words.back() += static_cast<char>(data[i]);
    }
  }
  std::string error;
  try {
    const auto command = parse_proxy_command(mode, words, error);
    if (!command) {
      TETHER_FUZZ_CHECK(!error.empty());
      return 0;
    }
    TETHER_FUZZ_CHECK(!command->name.empty());
    if (mode == proxy::Mode::primary) {
      const auto* message = std::get_if<proxy::ArduinoIn>(&command->message);
      TETHER_FUZZ_CHECK(message != nullptr);
      TETHER_FUZZ_CHECK(command->reset || message->data_case() != proxy::ArduinoIn::DATA_NOT_SET);
    } else {
      const auto* message = std::get_if<RocketryProto::ArduinoIn>(&command->message);
      TETHER_FUZZ_CHECK(message != nullptr);
      TETHER_FUZZ_CHECK(command->reset || message->data_case() != RocketryProto::ArduinoIn::DATA_NOT_SET);
    }
    std::string again_error;
    const auto again = parse_proxy_command(mode, words, again_error);
    TETHER_FUZZ_CHECK(again && serialized(*again) == serialized(*command));
  } catch (const std::exception& thrown) {
    std::fprintf(stderr, "parse_proxy_command threw: %s\n", thrown.what());
    TETHER_FUZZ_CHECK(false);
  }
  return 0;
}
