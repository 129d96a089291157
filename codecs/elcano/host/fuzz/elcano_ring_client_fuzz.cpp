// Fuzz target of the Elcano host node (RingClient: reading, capturing, forwarding with pacing, requests
// and their re-sends, receives, events), stateful: the input plays the ring. Byte 0 picks the generation
// (bit 4) and the capture set (TypeSet bits). Then each byte comes from the last board or, after an escape
// 0xFF, is a command:
//   0x00..0x3F  an operation with a message built from the command: send, request (reply type from the
//               command) or receive (command % 3);
//   0x40..0x7F  the ring gives back everything the host wrote since the last time (no board captured it);
//   0x80..0xFF  let the client catch up (wait until it handled everything delivered so far).
// Invariants: no crash, sanitizer finding or exception; every operation completes exactly once (the rest
// at close()); a request's reply is of the type asked for; what the host writes stays bounded by its
// operations (with their re-sends) and what it forwarded.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

#include "tether/elcano/client.hpp"
#include "tether/testing/fuzz_link.hpp"
#include "tether/testing/fuzz_target.hpp"

namespace {

using namespace tether;
using namespace tether::elcano;

constexpr Type kTypes[] = {Type::drive, Type::sensor, Type::goal, Type::segment};

Message sample(uint8_t selector) {
  Message m;
  m.type = kTypes[selector & 3u];
  m.number = selector;
  m.speed = static_cast<int32_t>(selector) * 37 - 1000;
  m.angle = -static_cast<int32_t>(selector);
  m.bearing = 7;
  m.east = 123456;
  m.north = -2147483647;
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::mutex written_mutex;
  std::vector<uint8_t> written;  // what the host wrote and the ring has not given back yet
  testing::FuzzLink link([&](const uint8_t* bytes, size_t n) {
    const std::lock_guard lock(written_mutex);
    if (written.size() < 65536) written.insert(written.end(), bytes, bytes + n);
  });
  Options options;
  options.node.generation = (data[0] & 0x10u) != 0 ? Generation::d : Generation::b;
  options.node.capture = TypeSet::from_bits(data[0]);
  options.receive_queue_bound = 4;
  options.send_queue_bound = 4;
  std::atomic<int> events{0};
  RingClient client(link.host_end(), options, [&events](const Event&) { ++events; });

  std::mutex mutex;
  std::vector<int> completions;
  std::atomic<int> completed{0};
  const auto started = [&] {
    const std::lock_guard lock(mutex);
    completions.push_back(0);
    return completions.size() - 1;
  };
  const auto complete = [&](size_t index) {
    {
      const std::lock_guard lock(mutex);
      TETHER_FUZZ_CHECK(++completions[index] == 1);
    }
    ++completed;
  };
  const auto operate = [&](uint8_t command) {
    const size_t index = started();
    const Message message = sample(command);
    switch (command % 3) {
      case 0:
        client.async_send(message, [&, index](error_code) { complete(index); });
        break;
      case 1: {
        const Type reply_type = kTypes[(command >> 2) & 3u];
        client.async_request(message, reply_type, [&, index, reply_type](error_code error, Message reply) {
          if (!error) TETHER_FUZZ_CHECK(reply.type == reply_type);
          complete(index);
        });
        break;
      }
      default:
        client.async_receive(Duration{50}, [&, index](error_code, Message) { complete(index); });
    }
  };

  testing::replay_input(link, data, size, [&](uint8_t command, size_t) -> size_t {
    if (command < 0x40) {
      operate(command);
    } else if (command < 0x80) {
      std::vector<uint8_t> back;
      {
        const std::lock_guard lock(written_mutex);
        back.swap(written);
      }
      if (!back.empty()) link.deliver(back.data(), back.size());
    } else {
      testing::catch_up(client.get_executor());
    }
    return 0;
  });
  const Counters counters = client.counters();
  client.close();
  TETHER_FUZZ_CHECK(testing::wait_for_fuzz([&] {
    const std::lock_guard lock(mutex);
    return completed.load() == static_cast<int>(completions.size());
  }));
  const uint32_t operations = static_cast<uint32_t>(completions.size());
  TETHER_FUZZ_CHECK(counters.bytes_written <=
                    (operations * options.timing.max_attempts + counters.ring.forwarded) * kMaxMessageBytes);
  return 0;
}
