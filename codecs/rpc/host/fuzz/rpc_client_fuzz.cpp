// Fuzz target of the rpc host client (rpc::Client on the tests' arm schema): frame decoding, the envelope
// and the schema's messages from the device, acks, re-sends, the Hello handshake, schema and session
// checks, streams; stateful: the input plays the device. Byte 0 seeds the first message id. Then each byte
// comes from the device or, after an escape 0xFF, is a command:
//   0x00..0x0F  a call of MoveJoint (joint = command);
//   0x10        open a stream of Watch (a new handle: the older one closes); 0x11 close it;
//   0x20        the device sends DeviceHello with the schema's hash (session 1); 0x21 with another hash;
//   0x22..0x2F  the device acks the last message id the client wrote (0x22..0x27: after a Reply of it,
//               0x28..0x2B: after a DeviceError of it, else alone);
//   0x30..0x3F  the device sends ResetEvent / DeviceHello with session = command;
//   0x40..0x7F  the next (command - 0x40) bytes are a payload the target frames as the device would;
//   0x80..0xFF  let the client catch up.
// Invariants: no crash, sanitizer finding or exception; every call completes exactly once (the rest at
// close()); a call without error has a reply; a closed stream's handler is not called once its close returned
// and a delivery then running has ended. The hand-written envelope (envelope.hpp) equals libprotobuf's: each
// raw payload (0x40..0x7F) is read the same by both (accepted or refused alike, the same fields), and each
// HostMessage the client writes is libprotobuf's serialization of what libprotobuf reads from it.
#include <google/protobuf/message.h>
#include <google/protobuf/reflection.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include "envelope_reference.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/client.hpp"
#include "tether/testing/fuzz_link.hpp"
#include "tether/testing/fuzz_target.hpp"
#include "tether_rpc.pb.h"

namespace {

using namespace tether;
using namespace tether::rpc;

const Schema& arm_schema() {
  static const Schema schema = Schema::load(std::string(TETHER_RPC_TEST_SCHEMAS) + "/arm.proto");
  return schema;
}

// What the client wrote, decoded as the device would (I/O thread): the last message id.
struct DeviceSide {
  std::mutex mutex;
  LinkCounters counters;
  proxy::Decoder<256> decoder{proxy::Integrity::crc16, counters};
  uint32_t last_id = 0;
  void on_written(const uint8_t* data, size_t size) {
    const std::lock_guard lock(mutex);
    for (size_t i = 0; i < size; ++i) {
      const DecodeStatus status = decoder.feed(data[i]);
      TETHER_FUZZ_CHECK(status != DecodeStatus::error);  // the client writes valid frames
      if (status != DecodeStatus::frame) continue;
      wire::HostMessage in;
      TETHER_FUZZ_CHECK(in.ParseFromArray(decoder.frame().data(), static_cast<int>(decoder.frame().size())));
      const std::string written(reinterpret_cast<const char*>(decoder.frame().data()), decoder.frame().size());
      TETHER_FUZZ_CHECK(in.SerializeAsString() == written);
      last_id = in.id();
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  DeviceSide device;
  testing::FuzzLink link([&device](const uint8_t* bytes, size_t n) { device.on_written(bytes, n); });
  Options options;
  options.timing.ping_period = 0;
  options.first_message_id = static_cast<uint32_t>(data[0]) << 24;
  Client client(link.host_end(), Schema::load(arm_schema().file()), options, [](const Event&) {});
  const std::uint64_t hash = arm_schema().hash();

  std::mutex mutex;
  std::vector<int> completions;
  std::atomic<int> completed{0};
  std::optional<Stream> stream;
  std::atomic<std::uint64_t> stream_generation{0};  // handlers of older generations must stay silent

  const auto deliver = [&](const wire::DeviceMessage& out) {
    const std::string payload = out.SerializeAsString();
    std::vector<uint8_t> frame(payload.size() + 16);
    const auto encoded = proxy::encode_frame(ByteView(reinterpret_cast<const uint8_t*>(payload.data()), payload.size()),
                                             proxy::Integrity::crc16, false, MutableByteView(frame.data(), frame.size()));
    TETHER_FUZZ_CHECK(encoded.ok());
    link.deliver(frame.data(), encoded.value());
  };
  const auto last_id = [&] {
    const std::lock_guard lock(device.mutex);
    return device.last_id;
  };

  testing::replay_input(link, data, size, [&](uint8_t command, size_t i) -> size_t {
    if (command < 0x10) {
      size_t index;
      {
        const std::lock_guard lock(mutex);
        completions.push_back(0);
        index = completions.size() - 1;
      }
      auto request = client.new_request("MoveJoint");
      request->GetReflection()->SetUInt32(request.get(), request->GetDescriptor()->FindFieldByName("joint"), command);
      client.async_call("MoveJoint", *request, [&, index](error_code error, CallResult result) {
        {
          const std::lock_guard lock(mutex);
          TETHER_FUZZ_CHECK(++completions[index] == 1);
        }
        TETHER_FUZZ_CHECK((result.reply != nullptr) == !error);
        ++completed;
      });
    } else if (command == 0x10) {
      stream.reset();
      testing::catch_up(client.get_executor());  // a delivery running during the close has ended
      const std::uint64_t generation = ++stream_generation;
      stream = client.open_stream("Watch", *client.new_request("Watch"), std::chrono::milliseconds(10),
                                  [&, generation](const error_code&, const StreamMessage&) {
                                    TETHER_FUZZ_CHECK(generation == stream_generation.load());
                                  });
    } else if (command == 0x11) {
      stream.reset();
      testing::catch_up(client.get_executor());
      ++stream_generation;
    } else if (command == 0x20 || command == 0x21) {
      wire::DeviceMessage out;
      out.mutable_hello()->set_schema_hash(command == 0x20 ? hash : hash ^ 1u);
      out.mutable_hello()->set_session(1);
      deliver(out);
    } else if (command < 0x30) {
      const uint32_t id = last_id();
      wire::DeviceMessage answer;
      if (command < 0x28) {
        answer.mutable_reply()->set_call(id);
        answer.mutable_reply()->set_reply(std::string("\x08\x05", 2));
        deliver(answer);
      } else if (command < 0x2C) {
        answer.mutable_error()->set_call(id);
        answer.mutable_error()->set_code(command);
        answer.mutable_error()->set_text("fuzz");
        deliver(answer);
      }
      wire::DeviceMessage ack;
      ack.mutable_ack()->set_id(id);
      deliver(ack);
    } else if (command < 0x40) {
      wire::DeviceMessage out;
      if ((command & 1u) != 0) {
        out.mutable_reset()->set_session(command);
      } else {
        out.mutable_hello()->set_schema_hash(hash);
        out.mutable_hello()->set_session(command);
      }
      deliver(out);
    } else if (command < 0x80) {
      const size_t length = std::min<size_t>(command - 0x40u, size - i - 1);
      TETHER_FUZZ_CHECK(rpc::envelope_reference::compare_decoders(std::string(reinterpret_cast<const char*>(data + i + 1), length)).empty());
      std::vector<uint8_t> frame(length + 16);
      const auto encoded = proxy::encode_frame(ByteView(data + i + 1, length), proxy::Integrity::crc16, false,
                                               MutableByteView(frame.data(), frame.size()));
      TETHER_FUZZ_CHECK(encoded.ok());
      link.deliver(frame.data(), encoded.value());
      return length;
    } else {
      testing::catch_up(client.get_executor());
    }
    return 0;
  });
  stream.reset();
  client.close();
  TETHER_FUZZ_CHECK(testing::wait_for_fuzz([&] {
    const std::lock_guard lock(mutex);
    return completed.load() == static_cast<int>(completions.size());
  }));
  return 0;
}
