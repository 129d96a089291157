// Fuzz target of the rpc device runtime (codecs/rpc/device): frame decoder, envelope decode, the method
// table's request decode, duplicate cache, streams and timers, on the tests' arm schema. Each byte is a byte
// from the host or, after an escape 0xFF, a command:
//   0x00..0x7F  the clock advances by (command * 100) ms (past the 10 s failsafe), then `poll`;
//   0x80..0xBF  `poll` at the same time;
//   0xC0..0xFF  the next (command - 0xC0) bytes are a payload the target frames itself (COBS + CRC-16) and
//               feeds, so the fuzzer reaches the envelope and the handlers without guessing checksums.
// Invariants: no crash or sanitizer finding; the device sends whole frames whose payloads decode as a
// DeviceMessage; every decoded HostMessage is acked exactly once; handlers never run for a re-send; after
// Reset the device restarts and stays consistent.
#include <pb_decode.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "arm.pb.h"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/device/rpc_device.hpp"
#include "tether/testing/fuzz_target.hpp"
#include "tether_rpc.pb.h"

// The arm schema's encoders and decoders, as the generated service code has them.
TETHER_RPC_MESSAGE_DECLARE(arm_JointRequest)
TETHER_RPC_MESSAGE_DECLARE(arm_JointReply)
TETHER_RPC_MESSAGE_DECLARE(arm_StateRequest)
TETHER_RPC_MESSAGE_DECLARE(arm_State)
TETHER_RPC_MESSAGE_DEFINE(arm_JointRequest)
TETHER_RPC_MESSAGE_DEFINE(arm_JointReply)
TETHER_RPC_MESSAGE_DEFINE(arm_StateRequest)
TETHER_RPC_MESSAGE_DEFINE(arm_State)

namespace {

using namespace tether;
using tether::rpc::Status;

uint32_t handler_runs = 0;

Status move_joint(const void* request, void* reply) {
  ++handler_runs;
  const auto& in = *static_cast<const arm_JointRequest*>(request);
  if (in.joint > 5) return Status::error(3, "no such joint");
  static_cast<arm_JointReply*>(reply)->reached_cdeg = in.angle_cdeg;
  return Status::ok();
}

Status watch(const void* request, void* reply) {
  (void)request;
  ++handler_runs;
  auto& out = *static_cast<arm_State*>(reply);
  out.angles_cdeg_count = static_cast<pb_size_t>(handler_runs % 9);  // up to 8 values: some too large
  for (pb_size_t i = 0; i < out.angles_cdeg_count; ++i) out.angles_cdeg[i] = -1;
  out.millis = handler_runs;
  return handler_runs % 7 == 0 ? Status::error(5, "sensor") : Status::ok();
}

const rpc::device::Method kMethods[] = {
    {&tether_rpc_decode_arm_JointRequest, &tether_rpc_encode_arm_JointReply, &move_joint, false},
    {&tether_rpc_decode_arm_StateRequest, &tether_rpc_encode_arm_State, &watch, true},
};
const rpc::device::Service kService{0x1234, kMethods, 2};

// What the device sent, read as a host reads it.
struct HostView {
  LinkCounters counters;
  proxy::Decoder<128> decoder{proxy::Integrity::crc16, counters};
  uint32_t acks = 0;
  bool restart_requested = false;

  static void write(void* self, ByteView frame) {
    auto& view = *static_cast<HostView*>(self);
    for (const uint8_t byte : frame) view.feed(byte);
    TETHER_FUZZ_CHECK(!view.decoder.in_frame());  // the sink gets whole frames
  }
  static void restart(void* self) { static_cast<HostView*>(self)->restart_requested = true; }

  void feed(uint8_t byte) {
    const DecodeStatus status = decoder.feed(byte);
    TETHER_FUZZ_CHECK(status != DecodeStatus::error);
    if (status != DecodeStatus::frame) return;
    tether_rpc_wire_DeviceMessage out = tether_rpc_wire_DeviceMessage_init_zero;
    pb_istream_t stream = pb_istream_from_buffer(decoder.frame().data(), decoder.frame().size());
    TETHER_FUZZ_CHECK(pb_decode(&stream, tether_rpc_wire_DeviceMessage_fields, &out));
    if (out.which_body == tether_rpc_wire_DeviceMessage_ack_tag) ++acks;
  }
};

std::vector<uint8_t> framed(const uint8_t* payload, size_t size) {
  std::vector<uint8_t> frame(size + 16);
  const auto encoded = proxy::encode_frame(ByteView(payload, size), proxy::Integrity::crc16, false,
                                           MutableByteView(frame.data(), frame.size()));
  TETHER_FUZZ_CHECK(encoded.ok());
  frame.resize(encoded.value());
  return frame;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Millis now = 0xFFFF0000u;  // cross the clock's wrap on long inputs
  HostView host;
  std::optional<rpc::device::Device<>> device;
  uint32_t session = 1;
  uint32_t acks_expected = 0;  // acks of earlier sessions
  handler_runs = 0;
  const auto boot = [&] {
    device.reset();
    device.emplace(kService, rpc::device::FrameSink{&HostView::write, &host}, &HostView::restart, &host);
    device->set_min_period_ms(2);
    device->begin(session++, now);
  };
  const auto check = [&] {
    const rpc::device::DeviceCounters& c = device->counters();
    const uint32_t decoded = c.link.frames_ok - c.decode_errors;
    TETHER_FUZZ_CHECK(host.acks == acks_expected + decoded);
    TETHER_FUZZ_CHECK(c.calls <= decoded);
    TETHER_FUZZ_CHECK(c.handler_errors <= handler_runs);
    if (host.restart_requested) {  // Reset: the real device reboots here
      host.restart_requested = false;
      acks_expected = host.acks;
      boot();
    }
  };
  boot();
  const auto feed = [&](uint8_t byte) {
    device->handle_byte(byte, now);
    check();
  };
  for (size_t i = 0; i < size; ++i) {
    if (data[i] != 0xFF || i + 1 >= size) {
      feed(data[i]);
      continue;
    }
    const uint8_t command = data[++i];
    if (command < 0xC0) {
      if (command < 0x80) now += command * 100u;
      device->poll(now);
      check();
      continue;
    }
    const size_t length = std::min<size_t>(command - 0xC0u, size - i - 1);
    const uint32_t runs_before = handler_runs;
    const uint32_t duplicates_before = device->counters().link.duplicates;
    for (const uint8_t byte : framed(data + i + 1, length)) feed(byte);
    if (device && device->counters().link.duplicates != duplicates_before) {
      TETHER_FUZZ_CHECK(handler_runs == runs_before);  // a re-send runs nothing
    }
    i += length;
  }
  now += rpc::device::DeviceCore::kPingSilenceMs;
  device->poll(now);
  check();
  return 0;
}
