// The `rpc-example` image: examples/rpc/arm.proto's service on an Arduino Uno, on the bare-metal runtime.
// UART0 at 115200 8N1; frames COBS(crc16 ‖ tether.rpc message) ‖ 00 (tether/rpc/device/rpc_device.hpp);
// the boot's session id as the proxy image's (tether/proxy/device/session_id.hpp: the last 8 bytes of
// EEPROM and SRAM noise); Reset through the watchdog.
//
// The arm is simulated and ideal: MoveJoint sets a joint's angle at once (what Watch reports), so every
// answer follows from the calls before it. Each MoveJoint that runs is recorded by the execution witness
// (tether/core/execution_witness.hpp) with the key witness_key(joint, uint16_t(angle_cdeg)).
//
// Buffers: RX ring 128 bytes (the host keeps at most 4 messages of <= 45 bytes in flight, and the loop
// reads faster than the line delivers except while it waits for TX room); TX ring 64 bytes (a reply and
// its ack, or a stream message, are <= 2 frames of <= 78 bytes: `write` waits for room for the rest).
#include <avr/pgmspace.h>

#include "ArmRpc_service.h"
#include "tether/core/bytes.hpp"
#include "tether/core/execution_witness.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/proxy/device/session_id.hpp"

namespace {

using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;
// The shortest stream period: one frame of the largest stream message at the baud (10 bits a byte),
// rounded up, so that a stream never sends faster than the line carries it.
constexpr uint16_t kMinPeriodMs = static_cast<uint16_t>(
    (tether::proxy::max_frame_size(ArmRpcService::Limits::kMaxOutPayload) * 10u * 1000u + kBaud - 1u) / kBaud);

constexpr uint8_t kJoints = 4;
constexpr int32_t kMinCdeg = -18000;
constexpr int32_t kMaxCdeg = 18000;

// The simulated arm.
struct Arm {
  int32_t angles[kJoints];
  arm_Mode mode;
  uint32_t moves;
};
Arm arm;

void write_frame(void*, tether::ByteView frame) { Serial::write(frame); }

void restart(void*) {
  Serial::flush();  // the Reset's ack must leave the UART first
  tether::firmware::system_reset();
}

ArmRpcService::Device device(ArmRpcService::service(), tether::rpc::device::FrameSink{write_frame, nullptr}, restart);

}  // namespace

tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  if (request.joint >= kJoints) return tether::rpc::Status::error(1, "no such joint");
  if (request.angle_cdeg < kMinCdeg || request.angle_cdeg > kMaxCdeg) {
    return tether::rpc::Status::error(2, "angle out of range");
  }
  if (arm.mode == arm_Mode_MODE_HOLD) return tether::rpc::Status::error(3, "arm on hold");
  arm.angles[request.joint] = request.angle_cdeg;
  ++arm.moves;
  tether::witness_executed(tether::witness_key(static_cast<uint16_t>(request.joint),
                                               static_cast<uint16_t>(request.angle_cdeg)));
  reply.reached_cdeg = request.angle_cdeg;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State& next) {
  next.angles_cdeg_count = kJoints;
  for (uint8_t i = 0; i < kJoints; ++i) next.angles_cdeg[i] = arm.angles[i];
  next.millis = tether::firmware::millis();
  next.mode = arm.mode;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_SetMode(const arm_ModeRequest& request, arm_ModeReply& reply) {
  reply.previous = arm.mode;
  arm.mode = request.mode;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Describe(const arm_DescribeRequest&, arm_Description& reply) {
  strncpy_P(reply.name, PSTR("tether-arm"), sizeof reply.name - 1);
  reply.joints = kJoints;
  reply.has_range = true;
  reply.range.min_cdeg = kMinCdeg;
  reply.range.max_cdeg = kMaxCdeg;
  reply.moves = arm.moves;
  return tether::rpc::Status::ok();
}

TETHER_UART0_ISRS(Serial);

int main() {
  // First, before interrupts and before the stack grows: it reads the untouched SRAM (session_id.hpp).
  const uint32_t session_id = tether::proxy::device::boot_session_id();
  tether::firmware::runtime_init<Serial>(kBaud);
  device.set_min_period_ms(kMinPeriodMs);
  device.begin(session_id, tether::firmware::millis());  // end of setup: ResetEvent
  for (;;) {
    // What the RX ring holds, read in place: a frame's bytes go through the decoder's run loop.
    const tether::ByteView received = Serial::peek();
    if (!received.empty()) {
      Serial::consume(static_cast<uint8_t>(device.handle_bytes(received, tether::firmware::millis())));
    }
    device.poll(tether::firmware::millis());
    if (received.empty()) tether::firmware::idle<Serial>();
  }
}
