// Fuzz target of the Romi device library's dispatcher (RomiSerial): its byte loop, handlers and reply
// cache, with a fake clock. The input is what the host sends, with commands after an escape byte 0xFF:
//   0x00..0x3F  the clock advances by (command * 40) ms (up to 2.5 s: past the request deadline and the
//               reply cache's lifetime), and the next byte comes at that time (a device that slept);
//   0x40..0x7F  the same step of (command - 0x40) * 40 ms, then `handle_timeouts` runs, as a main loop would;
//   0x80..0xBF  `handle_timeouts` at the same time;
//   0xC0..0xFF  the next (command - 0xC0) bytes arrive together through the input stream and one
//               `handle_input()` reads them (the Arduino loop); other bytes go through `handle_byte`.
// Invariants: no crash or sanitizer finding; everything the device writes is whole, valid response or
// log frames (a host decoder sees no error); at most one response per '#' received; every handler run is
// counted once; exactly-once: an intact re-send of the request that just ran, well inside the cache's
// lifetime, is answered from the cache without running again, and one well past the lifetime runs again
// (the cache must not make a new session's first command vanish).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <optional>
#include <vector>

#include "tether/romi/device/romi_serial.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::romi;
using namespace tether::romi::device;

class QueueStreams final : public IInputStream, public IOutputStream {
 public:
  bool available() override { return !input.empty(); }
  bool read(char& c) override {
    if (input.empty()) return false;
    c = static_cast<char>(input.front());
    input.pop_front();
    return true;
  }
  bool write(char c) override {
    output.push_back(static_cast<uint8_t>(c));
    return true;
  }
  std::deque<uint8_t> input;
  std::vector<uint8_t> output;
};

uint32_t fake_now = 0;
uint32_t fake_clock() { return fake_now; }
uint32_t runs = 0;

void ok(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_ok();
}
void values(IRomiSerial* romi, int16_t* args, const char*) {
  ++runs;
  romi->send(args[0] > 0 ? "[0,1,2]" : "[0,\"a:b\"]");
}
void echo_string(IRomiSerial* romi, int16_t*, const char* text) {
  ++runs;
  romi->log(text);
  romi->send_error(101, text);
}
void silent(IRomiSerial*, int16_t*, const char*) { ++runs; }
void twice(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send_ok();
  romi->send("[0]");
}
void too_long(IRomiSerial* romi, int16_t*, const char*) {
  ++runs;
  romi->send("[0,\"0123456789012345678901234567890123456789012345678901234567890123456789\"]");
}
void slow(IRomiSerial* romi, int16_t*, const char*) {  // works for 300 ms before answering
  ++runs;
  fake_now += 300;
  romi->send_ok();
}

const MessageHandler kHandlers[] = {
    {'a', 0, false, ok},    {'c', 2, false, values}, {'m', 12, false, ok},    {'t', 0, true, echo_string},
    {'b', 0, false, silent}, {'2', 0, false, twice},  {'L', 0, false, too_long}, {'w', 1, false, slow},
};

// What the device wrote, as a host reads it: whole frames, no error.
struct HostView {
  LinkCounters counters;
  Decoder<kHostDecoderCapacity> decoder{counters};
  uint32_t responses = 0;
  void read(std::vector<uint8_t>& output) {
    for (const uint8_t byte : output) {
      const DecodeStatus status = decoder.feed(byte);
      TETHER_FUZZ_CHECK(status != DecodeStatus::error);
      if (status == DecodeStatus::frame && !decoder.frame().log) {
        TETHER_FUZZ_CHECK(decoder.frame().has_id);
        ++responses;
      }
    }
    output.clear();
  }
};

// The last request that ran a handler and was not disturbed since, as the host sent it.
struct LastRun {
  uint8_t id = 0;
  std::vector<uint8_t> payload;
  uint32_t sent_at = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fake_now = 0xFFFFF000u;  // long inputs cross the clock's wrap
  runs = 0;
  QueueStreams streams;
  RomiSerial device(streams, streams, kHandlers, sizeof kHandlers / sizeof kHandlers[0], fake_clock);
  HostView host;
  uint32_t starts = 0;  // '#' bytes received
  // A mirror of the device's request decoder: which request each byte completes.
  LinkCounters mirror_counters;
  std::optional<Decoder<kDeviceDecoderCapacity>> mirror;
  mirror.emplace(mirror_counters);
  std::optional<LastRun> last;

  const auto check_output = [&] {
    host.read(streams.output);
    TETHER_FUZZ_CHECK(host.responses <= starts);
    TETHER_FUZZ_CHECK(device.counters().executed == runs);
  };
  const auto timeouts = [&] {
    const uint32_t dropped = device.counters().link.partial_timeouts;
    device.handle_timeouts(fake_now);
    if (device.counters().link.partial_timeouts != dropped) {  // the device forgot the partial request
      mirror.emplace(mirror_counters);
    }
    check_output();
  };

  for (size_t i = 0; i < size; ++i) {
    if (data[i] == 0xFF && i + 1 < size) {
      const uint8_t command = data[++i];
      if (command < 0x40) {
        fake_now += command * 40u;
      } else if (command < 0x80) {
        fake_now += (command - 0x40u) * 40u;
        timeouts();
      } else if (command < 0xC0) {
        timeouts();
      } else {
        // A batch through the stream: the mirror cannot tell which request ran, so it starts over.
        const size_t count = command - 0xC0u;
        for (size_t n = 0; n < count && i + 1 < size; ++n) {
          const uint8_t byte = data[++i];
          if (byte == '#') ++starts;
          streams.input.push_back(byte);
        }
        device.handle_input();
        TETHER_FUZZ_CHECK(streams.input.empty());
        mirror.emplace(mirror_counters);
        last.reset();
        check_output();
      }
      continue;
    }
    const uint8_t byte = data[i];
    if (byte == '#') ++starts;
    const DecodeStatus seen_status = mirror->feed(byte);
    const Frame& seen = mirror->frame();  // valid until the mirror's next feed
    const uint32_t runs_before = runs;
    const uint32_t duplicates_before = device.counters().link.duplicates;
    const uint32_t timeouts_before = device.counters().link.partial_timeouts;
    device.handle_byte(byte, fake_now);
    check_output();
    if (device.counters().link.partial_timeouts != timeouts_before) {
      mirror.emplace(mirror_counters);
      last.reset();
      continue;
    }
    if (seen_status == DecodeStatus::more || (seen_status == DecodeStatus::frame && seen.log)) continue;
    const bool answered_from_cache = device.counters().link.duplicates != duplicates_before;
    if (seen_status == DecodeStatus::error || seen.manual) {
      TETHER_FUZZ_CHECK(!answered_from_cache);
      if (seen_status == DecodeStatus::error) last.reset();
      continue;
    }
    const bool same_as_last = last && last->id == seen.id && last->payload.size() == seen.payload.size() &&
                              std::memcmp(last->payload.data(), seen.payload.data(), seen.payload.size()) == 0;
    if (answered_from_cache) {
      TETHER_FUZZ_CHECK(runs == runs_before);
    }
    if (same_as_last) {
      const uint32_t age = fake_now - last->sent_at;
      if (age + 1 < RomiSerial::kReplyCacheLifetimeMs) TETHER_FUZZ_CHECK(answered_from_cache && runs == runs_before);
      if (age > RomiSerial::kReplyCacheLifetimeMs + 1) TETHER_FUZZ_CHECK(!answered_from_cache);
    }
    if (runs != runs_before) {
      last = LastRun{seen.id, std::vector<uint8_t>(seen.payload.data(), seen.payload.data() + seen.payload.size()),
                     fake_now};
    } else if (!same_as_last) {
      last.reset();  // another request (an error answer) may have replaced the cached reply
    }
  }
  timeouts();
  return 0;
}
