// Fuzz target of what `tether monitor`, `shell` and `call` make of an rpc device and of typed requests:
// frames through the monitor's decoder with the arm schema (either direction: envelope, requests, replies,
// stream messages by name), every client event and device error as a shell line, and random words as a
// request's FIELD=VALUE arguments (or JSON) whose filled message prints as JSON that parses. Input and
// invariants: tools/tether/text_fuzzing.hpp (byte 0, bit 1 of a shell line: request words instead of events).
#include <fuzzer/FuzzedDataProvider.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/stubs/logging.h>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rpc_text.hpp"
#include "tether/rpc/plugin.hpp"
#include "text_fuzzing.hpp"

namespace {

using namespace tether;
using namespace tether::cli;

const rpc::Schema& arm_schema() {
  static const rpc::Schema schema = rpc::Schema::load(std::string(TETHER_RPC_TEST_SCHEMAS) + "/arm.proto");
  return schema;
}

rpc::Event rpc_event(std::uint8_t which, FuzzedDataProvider& input) {
  namespace ev = rpc::events;
  switch (which % 5) {
    case 0:
      return ev::SessionEstablished{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint8_t>(),
                                    input.ConsumeBool()};
    case 1:
      return ev::ResetDetected{input.ConsumeIntegral<std::uint32_t>(), input.ConsumeIntegral<std::uint32_t>()};
    case 2:
      return ev::SchemaMismatch{input.ConsumeIntegral<std::uint64_t>(), input.ConsumeIntegral<std::uint64_t>(),
                                input.ConsumeRemainingBytesAsString()};
    case 3:
      return ev::DeviceErrorReport{{input.ConsumeIntegral<std::uint16_t>(), input.ConsumeRemainingBytesAsString()}};
    default:
      return ev::LinkFailed{rpc::error_code(input.ConsumeIntegral<int>(), boost::system::generic_category())};
  }
}

void check_request(FuzzedDataProvider& input) {
  const rpc::Schema& schema = arm_schema();
  const rpc::Method& method = schema.methods()[input.ConsumeIntegral<std::uint8_t>() % schema.methods().size()];
  google::protobuf::DynamicMessageFactory factory(&schema.pool());
  std::unique_ptr<google::protobuf::Message> request(factory.GetPrototype(method.input)->New());
  std::vector<std::string> words;
  while (input.remaining_bytes() > 0 && words.size() < 8) words.push_back(input.ConsumeRandomLengthString(40));
  const auto error = fill_rpc_request(*request, words);
  TETHER_FUZZ_CHECK(!error || !error->empty());
  const std::string json = rpc_message_json(*request);
  TETHER_FUZZ_CHECK(nlohmann::json::accept(json));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);  // no "invalid UTF-8" log line per generated input
    return true;
  }();
  static_cast<void>(quiet);
  const std::uint8_t selector = data[0];
  if (fuzzes_monitor(selector)) {
    devices::DeviceConfig config;
    config.codec = rpc::kCodec;
    rpc::DeviceOptions options;
    if ((selector & 0x02) == 0) options.schema = std::string(TETHER_RPC_TEST_SCHEMAS) + "/arm.proto";  // else: envelope only
    config.options = options;
    check_monitor_decoding(config, data, size);
    return 0;
  }
  FuzzedDataProvider input(data + 1, size - 1);
  if ((selector & 0x02) != 0) {
    check_request(input);
    return 0;
  }
  const std::uint8_t which = input.ConsumeIntegral<std::uint8_t>();
  if (which >= 0xF0) {
    const bool refused = input.ConsumeBool();
    const rpc::DeviceError answer{input.ConsumeIntegral<std::uint16_t>(), input.ConsumeRemainingBytesAsString()};
    check_shell_line("answer", rpc_device_error_line("MoveJoint", refused ? rpc::RpcError::refused : rpc::RpcError::device_error,
                                                     answer));
    return 0;
  }
  check_shell_line("event", rpc_event_line(rpc_event(which, input)));
  return 0;
}
