// The `rpc-example` image: examples/rpc/arm.proto's service on an Arduino Uno, on the bare-metal runtime.
// UART0 at 115200 8N1; frames COBS(crc16 ‖ tether.rpc message) ‖ 00 (tether/rpc/device/rpc_device.hpp);
// the boot's session id as the proxy image's (tether/proxy/device/session_id.hpp: the last 8 bytes of
// EEPROM and SRAM noise); Reset through the watchdog.
//
// The arm is simulated and ideal: MoveJoint sets a joint's angle at once (what Watch reports), so every
// answer follows from the calls before it. Each MoveJoint that runs is recorded by the execution witness
// (tether/core/execution_witness.hpp) with the key witness_key(joint, uint16_t(angle_cdeg)).
//
// RAM: the device runtime's static tables (~0.45 KB: the receive buffer, the exactly-once cache, the
// counters; the method table is in flash) and its stack at the deepest point (a call's request and reply
// structs, its answer being encoded and framed) leave little of the 2 KB: the UART rings are small (RX 32
// bytes: the loop takes bytes as they come and decodes them in place; TX 16 bytes: `write` waits for room,
// ~1.5 ms for a 16-byte frame), the handlers' error texts in flash (Status::error_P) and the device's entry
// points out of line (below).
#include <avr/pgmspace.h>

#include "ArmRpc_service.h"
#include "tether/core/bytes.hpp"
#include "tether/core/execution_witness.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/proxy/device/session_id.hpp"

namespace {

using Serial = tether::firmware::Uart0<32, 16>;
constexpr uint32_t kBaud = 115200;
// The shortest stream period: one frame of the largest stream message at the baud (10 bits a byte),
// rounded up, so that a stream never sends faster than the line carries it.
constexpr uint16_t kMinPeriodMs = static_cast<uint16_t>(
    (static_cast<uint32_t>(tether::proxy::max_frame_size(ArmRpcService::Limits::kMaxOutPayload)) * 10u * 1000u + kBaud -
     1u) /
    kBaud);
static_assert(kMinPeriodMs == 7, "a 76-byte frame takes 6.6 ms at 115200 baud");

constexpr uint8_t kJoints = 4;
constexpr int32_t kMinCdeg = -18000;
constexpr int32_t kMaxCdeg = 18000;

// The simulated arm.
struct Arm {
  int32_t angles[kJoints];
  int32_t min_cdeg;
  int32_t max_cdeg;
  arm_Mode mode;
  uint32_t moves;
};
Arm arm = {{0, 0, 0, 0}, kMinCdeg, kMaxCdeg, arm_Mode_MODE_IDLE, 0};

// The handlers' error texts, in flash (Status::error_P).
const char kNoJoint[] PROGMEM = "no joint";
const char kOutOfRange[] PROGMEM = "out of range";
const char kOnHold[] PROGMEM = "on hold";

void write_frame(void*, tether::ByteView frame) { Serial::write(frame); }

void restart(void*) {
  Serial::flush();  // the Reset's ack must leave the UART first
  tether::firmware::system_reset();
}

// Bound in `start`: made without arguments it is all zeros, in .bss (its ~0.45 KB image would otherwise be
// in flash as .data).
ArmRpcService::Device device;

}  // namespace

tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  if (request.joint >= kJoints) return tether::rpc::Status::error_P(1, kNoJoint);
  if (request.angle_cdeg < arm.min_cdeg || request.angle_cdeg > arm.max_cdeg) {
    return tether::rpc::Status::error_P(2, kOutOfRange);
  }
  if (arm.mode == arm_Mode_MODE_HOLD) return tether::rpc::Status::error_P(3, kOnHold);
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
  if (request.has_range) {
    const arm_ModeRequest_Range& range = request.range;
    if (range.min_cdeg > range.max_cdeg || range.min_cdeg < kMinCdeg || range.max_cdeg > kMaxCdeg) {
      return tether::rpc::Status::error_P(2, kOutOfRange);
    }
    arm.min_cdeg = range.min_cdeg;
    arm.max_cdeg = range.max_cdeg;
  }
  reply.previous = arm.mode;
  arm.mode = request.mode;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Describe(const arm_DescribeRequest&, arm_Description& reply) {
  strncpy_P(reply.name, PSTR("tether-arm"), sizeof reply.name - 1);
  reply.joints = kJoints;
  reply.min_cdeg = arm.min_cdeg;
  reply.max_cdeg = arm.max_cdeg;
  reply.moves = arm.moves;
  return tether::rpc::Status::ok();
}

namespace {

// The device's entry points out of line: each puts its answer buffers on the stack for its own run
// (rpc_device.hpp's Buffers); inlined into main, the compiler keeps their room in main's frame for good,
// ~150 bytes each under the deepest point (a call's reply).
__attribute__((noinline)) void start(uint32_t session_id) {
  device.bind(ArmRpcService::service(), tether::rpc::device::FrameSink{write_frame, nullptr}, restart);
  device.set_min_period_ms(kMinPeriodMs);
  device.begin(session_id, tether::firmware::millis());  // end of setup: ResetEvent
}
__attribute__((noinline)) size_t handle(tether::ByteView received) {
  return device.handle_bytes(received, tether::firmware::millis());
}
__attribute__((noinline)) void poll() { device.poll(tether::firmware::millis()); }

// Sleeps until a byte arrives or the clock ticks: a wake by the transmitter alone (one per byte sent,
// ~30 a stream message) goes back to sleep without a loop pass, as nothing can have come due. The tick
// is seen in the clock's low byte (one load, no interrupt lock: each of those wakes is cheaper).
void sleep_until_work() {
  const uint8_t at = tether::firmware::millis_low_byte();
  do {
    tether::firmware::idle<Serial>();
  } while (Serial::available() == 0 && tether::firmware::millis_low_byte() == at);
}

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  // First, before interrupts and before the stack grows: it reads the untouched SRAM (session_id.hpp).
  const uint32_t session_id = tether::proxy::device::boot_session_id();
  tether::firmware::runtime_init<Serial>(kBaud);
  start(session_id);
  for (;;) {
    // What the RX ring holds, read in place: a frame's bytes go through the decoder's run loop.
    const tether::ByteView received = Serial::peek();
    if (!received.empty()) {
      Serial::consume(static_cast<uint8_t>(handle(received)));
    }
    poll();
    if (received.empty()) sleep_until_work();
  }
}
