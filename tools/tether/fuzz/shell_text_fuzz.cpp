// Fuzz target of what `tether shell` prints for what a device said: romi answers (the answer array parsed
// from device bytes, as the client does) and log lines, every proxy event (device texts, numbers, compat
// messages parsed from device bytes), Elcano ring events and captured messages (fields from the bytes),
// each rendered as the text line and the JSON line.
// Invariants: nothing throws (an exception would end the shell's I/O thread), no sanitizer finding, every
// JSON line has its type.
// Input: byte 0 picks the path, the rest fills the values (numbers little-endian, then text).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "cli_support.hpp"
#include "shell_text.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

// Takes values off the input, front to back; zeros when it runs out.
class InputBytes {
 public:
  InputBytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename Integer>
  Integer take() {
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < sizeof(Integer); ++i) value |= static_cast<std::uint64_t>(byte()) << (8 * i);
    return static_cast<Integer>(value);
  }
  bool flag() { return (byte() & 1) != 0; }
  /// The rest of the input, as is.
  std::string rest() {
    std::string text(reinterpret_cast<const char*>(data_ + position_), size_ - position_);
    position_ = size_;
    return text;
  }

 private:
  std::uint8_t byte() { return position_ < size_ ? data_[position_++] : 0; }
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

void render(std::string_view type, const ShellLine& line) {
  TETHER_FUZZ_CHECK(shell_output(type, line, false) == line.text);
  const std::string json = shell_output(type, line, true);
  TETHER_FUZZ_CHECK(json.rfind("{\"type\":", 0) == 0);
}

elcano::Message ring_message(InputBytes& input) {
  elcano::Message message;
  static constexpr elcano::Type kTypes[] = {elcano::Type::drive, elcano::Type::sensor, elcano::Type::goal,
                                            elcano::Type::segment};
  message.type = kTypes[input.take<std::uint8_t>() % 4];
  message.number = input.take<std::int32_t>();
  message.speed = input.take<std::int32_t>();
  message.angle = input.take<std::int32_t>();
  message.obstacle = input.take<std::int32_t>();
  message.bearing = input.take<std::int32_t>();
  message.probability = input.take<std::int32_t>();
  message.east = input.take<std::int32_t>();
  message.north = input.take<std::int32_t>();
  return message;
}

proxy::ProxyEvent proxy_event(std::uint8_t which, InputBytes& input) {
  namespace ev = proxy::events;
  switch (which % 12) {
    case 0: {
      ev::DeviceError error;
      error.level = input.flag() ? proxy::ErrorLevel::fatal : proxy::ErrorLevel::warning;
      error.text = input.rest();
      return error;
    }
    case 1:
      return ev::DeviceInfo{input.take<std::uint32_t>(), input.flag()};
    case 2:
      return ev::FailsafeTriggered{input.take<std::uint32_t>()};
    case 3: {
      ev::PinReport report;
      report.kind = static_cast<proxy::PinKind>(input.take<std::uint8_t>() % 3);
      report.pin = input.take<std::uint32_t>();
      report.value = input.take<std::int32_t>();
      report.failsafe = input.flag();
      return report;
    }
    case 4: {
      ev::PinLost lost;
      lost.kind = static_cast<proxy::PinKind>(input.take<std::uint8_t>() % 3);
      lost.pin = input.take<std::uint32_t>();
      lost.silent_ms = input.take<Duration>();
      return lost;
    }
    case 5:
      return ev::SessionEstablished{input.take<std::uint32_t>(), input.take<std::uint16_t>(), input.flag()};
    case 6:
      return ev::ResetDetected{input.take<std::uint32_t>(), input.take<std::uint32_t>()};
    case 7:
      return ev::CompatEvent{static_cast<RocketryProto::EventTypes>(input.take<std::int32_t>()),
                             input.take<std::int32_t>()};
    case 8:
      return ev::CompatError{static_cast<RocketryProto::ErrorTypes>(input.take<std::int32_t>()),
                             input.take<std::int32_t>()};
    case 9: {
      ev::CompatState state;
      const std::string payload = input.rest();
      static_cast<void>(state.message.ParseFromString(payload));  // what parsed, as the client would keep it
      return state;
    }
    case 10: {
      ev::UndecodableMessage undecodable;
      undecodable.malformed = input.flag();
      undecodable.payload = input.rest();
      return undecodable;
    }
    default:
      return ev::LinkFailed{proxy::error_code(input.take<int>(), boost::system::generic_category())};
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::uint8_t selector = data[0];
  InputBytes input(data + 1, size - 1);
  switch (selector % 5) {
    case 0: {  // a romi answer as the client builds it from the frame's payload
      romi::RomiResponse response;
      response.code = input.take<std::int16_t>();
      response.id = input.take<std::uint8_t>();
      response.attempts = input.take<std::uint8_t>();
      response.answered = input.flag();
      const std::string body = input.rest();
      auto values = nlohmann::json::parse(body.begin(), body.end(), nullptr, false);
      if (!values.is_discarded()) response.values = std::move(values);
      response.message = body;
      render("answer", romi_answer_line(body, response));
      break;
    }
    case 1:
      render("event", romi_log_line(input.rest()));
      break;
    case 2:
      render("event", proxy_event_line(proxy_event(input.take<std::uint8_t>(), input)));
      break;
    case 3: {
      elcano::ClientEvent event;
      event.kind = static_cast<elcano::ClientEvent::Kind>(input.take<std::uint8_t>() % 5);
      event.error = static_cast<elcano::ReadError>(input.take<std::uint8_t>() % 10);
      event.message = ring_message(input);
      event.link_error = elcano::error_code(input.take<int>(), boost::system::generic_category());
      const auto generation = input.flag() ? elcano::Generation::d : elcano::Generation::b;
      render("event", ring_event_line(event, generation));
      break;
    }
    default: {
      const elcano::Message message = ring_message(input);
      render("event", captured_line(message, input.flag() ? elcano::Generation::d : elcano::Generation::b));
      break;
    }
  }
  return 0;
}
