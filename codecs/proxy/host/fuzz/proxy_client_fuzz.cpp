// Fuzz target of the proxy host client (proxy::Client, both modes): frame decoding, protobuf decode of the
// device's messages, acks, re-sends, the session handshake and reset detection, pin reports and events,
// stateful: the input plays the device. Byte 0: bit 0 picks compat mode, the rest seeds the first
// messageId. Then each byte comes from the device or, after an escape 0xFF, is a command:
//   0x00..0x1F  a send: ServoInit/ServoControl/DigitalInit/DigitalControl (command % 4) on pin 8 + bits 2..3,
//               or PingFailsafeReset (bit 4);
//   0x20        restart_session();
//   0x21        the device acks the last messageId the client wrote (primary);
//   0x22..0x3F  the device sends ResetEvent (primary; EventMessage RESET in compat) with session id = command;
//   0x40..0x7F  the next (command - 0x40) bytes are a payload the target frames as the device would (COBS,
//               CRC-16 in primary mode): the fuzzer reaches protobuf decoding without guessing checksums;
//   0x80..0xFF  let the client catch up (wait until it handled everything delivered so far).
// Invariants: no crash, sanitizer finding or exception; every send completes exactly once (the rest at
// close()); primary: a send without error was acked; events reach the handler without throwing; the pin
// table stays bounded.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

#include "rocketry.pb.h"
#include "tether/proxy/client.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/fuzz_link.hpp"
#include "tether/testing/fuzz_target.hpp"
#include "tether_proxy.pb.h"

namespace {

using namespace tether;
using namespace tether::proxy;

// What the client wrote, decoded as the device would (I/O thread): the last messageId.
struct DeviceSide {
  explicit DeviceSide(Integrity mode) : integrity(mode), decoder(mode, counters) {}
  Integrity integrity;
  std::mutex mutex;
  LinkCounters counters;
  Decoder<256> decoder;
  uint32_t last_id = 0;
  void on_written(const uint8_t* data, size_t size) {
    const std::lock_guard lock(mutex);
    for (size_t i = 0; i < size; ++i) {
      const DecodeStatus status = decoder.feed(data[i]);
      TETHER_FUZZ_CHECK(status != DecodeStatus::error);  // the client writes valid frames
      if (status != DecodeStatus::frame || integrity == Integrity::none) continue;
      const ByteView payload = decoder.frame();
      ArduinoIn in;
      TETHER_FUZZ_CHECK(in.ParseFromArray(payload.data(), static_cast<int>(payload.size())));
      last_id = in.messageid();
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool compat = (data[0] & 1u) != 0;
  const Integrity integrity = compat ? Integrity::none : Integrity::crc16;
  DeviceSide device(integrity);
  testing::FuzzLink link([&device](const uint8_t* bytes, size_t n) { device.on_written(bytes, n); });
  Options options = compat ? Options::compat() : Options::primary();
  options.timing.ping_period = 0;
  options.first_message_id = static_cast<uint32_t>(data[0]) << 24;
  std::atomic<int> events{0};
  Client client(link.host_end(), options, [&events](const Event&) { ++events; });

  std::mutex mutex;
  std::vector<int> completions;
  std::atomic<int> completed{0};
  const auto send = [&](uint8_t command) {
    size_t index;
    {
      const std::lock_guard lock(mutex);
      completions.push_back(0);
      index = completions.size() - 1;
    }
    auto done = [&, index](error_code error, SendResult result) {
      {
        const std::lock_guard lock(mutex);
        TETHER_FUZZ_CHECK(++completions[index] == 1);
      }
      if (!compat) TETHER_FUZZ_CHECK(result.acked == !error);
      ++completed;
    };
    const uint32_t pin = 8u + ((command >> 2) & 3u);
    const int32_t value = command * 6;
    if (compat) {
      RocketryProto::ArduinoIn in;
      switch (command % 4) {
        case 0: in.mutable_servoinit()->set_pin(pin), in.mutable_servoinit()->set_safeposition(value); break;
        case 1: in.mutable_servocontrol()->set_pin(pin), in.mutable_servocontrol()->set_position(value); break;
        case 2: in.mutable_digitalinit()->set_pin(pin), in.mutable_digitalinit()->set_safestate(command & 1u); break;
        default: in.mutable_digitalcontrol()->set_pin(pin), in.mutable_digitalcontrol()->set_activate(true);
      }
      client.async_send(in, done);
      return;
    }
    ArduinoIn in;
    if ((command & 0x10u) != 0) {
      in.mutable_pingfailsafereset();
    } else {
      switch (command % 4) {
        case 0: in.mutable_servoinit()->set_pin(pin), in.mutable_servoinit()->set_safeposition(value); break;
        case 1: in.mutable_servocontrol()->set_pin(pin), in.mutable_servocontrol()->set_position(value); break;
        case 2: in.mutable_digitalinit()->set_pin(pin), in.mutable_digitalinit()->set_safestate(true); break;
        default: in.mutable_digitalcontrol()->set_pin(pin), in.mutable_digitalcontrol()->set_state(false);
      }
    }
    client.async_send(in, done);
  };
  const auto deliver_payload = [&](const std::string& payload) {
    std::vector<uint8_t> frame(payload.size() + 16);
    const auto encoded = encode_frame(ByteView(reinterpret_cast<const uint8_t*>(payload.data()), payload.size()),
                                      integrity, false, MutableByteView(frame.data(), frame.size()));
    TETHER_FUZZ_CHECK(encoded.ok());
    link.deliver(frame.data(), encoded.value());
  };

  testing::replay_input(link, data, size, [&](uint8_t command, size_t i) -> size_t {
    if (command < 0x20) {
      send(command);
    } else if (command == 0x20) {
      client.restart_session();
    } else if (command == 0x21) {
      if (!compat) {
        ArduinoOut out;
        {
          const std::lock_guard lock(device.mutex);
          out.mutable_ack()->set_messageid(device.last_id);
        }
        deliver_payload(out.SerializeAsString());
      }
    } else if (command < 0x40) {
      if (compat) {
        RocketryProto::ArduinoOut out;
        out.mutable_eventmessage()->set_type(RocketryProto::RESET);
        deliver_payload(out.SerializeAsString());
      } else {
        ArduinoOut out;
        out.mutable_resetevent()->set_sessionid(command);
        deliver_payload(out.SerializeAsString());
      }
    } else if (command < 0x80) {
      const size_t length = std::min<size_t>(command - 0x40u, size - i - 1);
      deliver_payload(std::string(reinterpret_cast<const char*>(data + i + 1), length));
      return length;
    } else {
      testing::catch_up(client.get_executor());
    }
    return 0;
  });
  TETHER_FUZZ_CHECK(client.pin_states().size() <= 256);
  client.close();
  TETHER_FUZZ_CHECK(testing::wait_for_fuzz([&] {
    const std::lock_guard lock(mutex);
    return completed.load() == static_cast<int>(completions.size());
  }));
  return 0;
}
