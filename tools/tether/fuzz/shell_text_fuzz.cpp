// Fuzz target of what `tether shell` prints for what a device said: romi answers (the answer array parsed
// from device bytes, as the client does) and log lines, every proxy event (device texts, numbers, compat
// messages parsed from device bytes), Elcano ring events and captured messages (fields from the bytes),
// each rendered as the text line and the JSON line.
// Invariants: nothing throws (an exception would end the shell's I/O thread), no sanitizer finding, every
// JSON line has its type.
// Input: byte 0 picks the path, the rest fills the values (FuzzedDataProvider: numbers, then text).
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "cli_support.hpp"
#include "shell_text.hpp"
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

proxy::Event proxy_event(std::uint8_t which, FuzzedDataProvider& input) {
  namespace ev = proxy::events;
  switch (which % 12) {
    case 0: {
      ev::DeviceError error;
      error.level = input.ConsumeBool() ? proxy::ErrorLevel::fatal : proxy::ErrorLevel::warning;
      error.text = input.ConsumeRemainingBytesAsString();
      return error;
    }
    case 1:
      return ev::DeviceInfo{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeBool()};
    case 2:
      return ev::FailsafeTriggered{input.ConsumeIntegral<std::uint32_t>()};
    case 3: {
      ev::PinReport report;
      report.kind = static_cast<proxy::PinKind>(input.ConsumeIntegral<std::uint8_t>() % 3);
      report.pin = input.ConsumeIntegral<std::uint32_t>();
      report.value = input.ConsumeIntegral<std::int32_t>();
      report.failsafe = input.ConsumeBool();
      return report;
    }
    case 4: {
      ev::PinLost lost;
      lost.kind = static_cast<proxy::PinKind>(input.ConsumeIntegral<std::uint8_t>() % 3);
      lost.pin = input.ConsumeIntegral<std::uint32_t>();
      lost.silent_ms = input.ConsumeIntegral<Duration>();
      return lost;
    }
    case 5:
      return ev::SessionEstablished{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint16_t>(),
                                    input.ConsumeBool()};
    case 6:
      return ev::ResetDetected{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint32_t>()};
    case 7:
      return ev::CompatEvent{static_cast<RocketryProto::EventTypes>(input.ConsumeIntegral<std::int32_t>()),
                             input.ConsumeIntegral<std::int32_t>()};
    case 8:
      return ev::CompatError{static_cast<RocketryProto::ErrorTypes>(input.ConsumeIntegral<std::int32_t>()),
                             input.ConsumeIntegral<std::int32_t>()};
    case 9: {
      ev::CompatState state;
      const std::string payload = input.ConsumeRemainingBytesAsString();
      static_cast<void>(state.message.ParseFromString(payload));  // what parsed, as the client would keep it
      return state;
    }
    case 10: {
      ev::UndecodableMessage undecodable;
      undecodable.malformed = input.ConsumeBool();
      undecodable.payload = input.ConsumeRemainingBytesAsString();
      return undecodable;
    }
    default:
      return ev::LinkFailed{proxy::error_code(input.ConsumeIntegral<int>(), boost::system::generic_category())};
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  FuzzedDataProvider input(data + 1, size - 1);
  switch (selector % 5) {
    case 0: {  // a romi answer as the client builds it from the frame's payload
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
      break;
    }
    case 1:
      render("event", romi_log_line(input.ConsumeRemainingBytesAsString()));
      break;
    case 2:
      render("event", proxy_event_line(proxy_event(input.ConsumeIntegral<std::uint8_t>(), input)));
      break;
    case 3: {
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
      break;
    }
    default: {
      const elcano::Message message = ring_message(input);
      render("event", captured_line(message, input.ConsumeBool() ? elcano::Generation::d : elcano::Generation::b));
      break;
    }
  }
  return 0;
}
