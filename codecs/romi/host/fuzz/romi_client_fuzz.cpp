// Fuzz target of the Romi host client's answer handling (romi::Client: envelope decoding, matching answers
// to calls, parse_answer and its JSON, log lines, stale frames, re-sends on envelope errors), stateful:
// the input plays the device. Each byte is a byte from the device or, after an escape 0xFF, a command:
//   0x00..0x3F  start a call (command % 8 picks one of the commands below; bit 5: manual form);
//   0x40..0x7F  the next (command - 0x40) bytes are an answer BODY that the target frames as a response
//               to the last request the client wrote (its opcode and id, a valid CRC), so the fuzzer
//               reaches parse_answer and the JSON without guessing checksums;
//   0x80..0xFF  let the client catch up (wait until it handled everything delivered so far).
// Invariants: no crash, sanitizer finding or exception; every call completes exactly once (the rest at
// close(), with operation_aborted); a completion without error carries an intact answer whose code is
// its first value; what the client writes stays bounded by its calls and their allowed sends.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

#include "tether/romi/client.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/testing/fuzz_link.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::romi;

const char* const kCommands[] = {"e", "s[2,3]", "t[\"hello\"]", "f", "g[1]", "S[1500,1500]", "a[1,2,3,4,5,6,7,8,9,10,11,12]", "?"};

// The requests the client wrote, decoded as a device would (I/O thread).
struct DeviceSide {
  std::mutex mutex;
  LinkCounters counters;
  Decoder<kDeviceDecoderCapacity> decoder{counters};
  char opcode = 'e';
  uint8_t id = 0;
  size_t written = 0;
  void on_written(const uint8_t* data, size_t size) {
    const std::lock_guard lock(mutex);
    written += size;
    for (size_t i = 0; i < size; ++i) {
      const DecodeStatus status = decoder.feed(data[i]);
      TETHER_FUZZ_CHECK(status != DecodeStatus::error);  // the client writes valid requests
      if (status != DecodeStatus::frame) continue;
      const Frame& frame = decoder.frame();
      opcode = frame.opcode;
      id = frame.manual ? 0 : frame.id;
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  DeviceSide device;
  testing::FuzzLink link([&device](const uint8_t* bytes, size_t n) { device.on_written(bytes, n); });
  Options options;
  options.first_id(data != nullptr && size > 0 ? data[0] : 0);
  Client client(link.host_end(), options);
  client.on_event([](const Event& event) {
    if (const auto* log = std::get_if<events::Log>(&event)) TETHER_FUZZ_CHECK(log->text.size() <= 4096);
  });

  // Completions: calls[i] counts how often call i completed.
  std::mutex mutex;
  std::vector<int> completions;
  std::atomic<int> completed{0};
  uint32_t calls = 0;
  const auto start_call = [&](uint8_t command) {
    const size_t index = completions.size();
    {
      const std::lock_guard lock(mutex);
      completions.push_back(0);
    }
    ++calls;
    auto handler = [&, index](error_code error, RomiResponse response) {
      {
        const std::lock_guard lock(mutex);
        TETHER_FUZZ_CHECK(++completions[index] == 1);
      }
      if (!error) {
        TETHER_FUZZ_CHECK(response.answered);
        TETHER_FUZZ_CHECK(response.values.is_array() && !response.values.empty());
        TETHER_FUZZ_CHECK(response.values[0].get<int64_t>() == response.code);
      }
      ++completed;
    };
    const Command text(kCommands[command % 8]);
    if ((command & 0x20u) != 0) {
      client.async_call_manual(text, handler);
    } else {
      client.async_call(text, handler);
    }
  };

  testing::replay_input(link, data, size, [&](uint8_t command, size_t i) -> size_t {
    if (command < 0x40) {
      start_call(command);
      return 0;
    }
    if (command < 0x80) {
      const size_t length = std::min<size_t>(command - 0x40u, size - i - 1);
      char opcode;
      uint8_t id;
      {
        const std::lock_guard lock(device.mutex);
        opcode = device.opcode;
        id = device.id;
      }
      uint8_t frame[256];
      const auto encoded = encode_response(opcode, ByteView(data + i + 1, length), id, MutableByteView(frame, sizeof frame));
      if (encoded.ok()) link.deliver(frame, encoded.value());
      return length;
    }
    testing::catch_up(client.get_executor());
    return 0;
  });
  client.close();
  TETHER_FUZZ_CHECK(testing::wait_for_fuzz([&] { return completed.load() == static_cast<int>(calls); }));
  {
    const std::lock_guard lock(device.mutex);
    const Options defaults;
    TETHER_FUZZ_CHECK(device.written <= (calls + 1) * defaults.timing.max_attempts * 80u);
  }
  return 0;
}
