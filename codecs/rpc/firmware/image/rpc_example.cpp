// The `rpc-example` image: examples/rpc/arm.proto's service on an Arduino Uno, on the bare-metal runtime.
// UART0 at 115200 8N1; frames COBS(crc16 ‖ tether.rpc message) ‖ 00 (tether/rpc/device/rpc_device.hpp);
// the boot's session id as the proxy image's (tether/proxy/device/session_id.hpp: the last 8 bytes of
// EEPROM and SRAM noise); Reset through the watchdog.
//
// The arm is simulated and ideal: MoveJoint sets a joint's angle at once (what Watch reports), so every
// answer follows from the calls before it. Each MoveJoint that runs is recorded by the execution witness
// (tether/core/execution_witness.hpp) with the key witness_key(joint, uint16_t(angle_cdeg)).
//
// The main loop is every image's (uart_device.hpp).
#include <avr/pgmspace.h>

#include "ArmRpc_service.h"
#include "tether/core/execution_witness.hpp"
#include "uart_device.hpp"

namespace {

constexpr uint32_t kBaud = 115200;
static_assert(tether::rpc::image::min_period_ms<ArmRpcService::Limits>(kBaud) == 7,
              "a 76-byte frame takes 6.6 ms at 115200 baud");

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

// Bound at start: made without arguments it is all zeros, in .bss (its ~0.45 KB image would otherwise be
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

TETHER_UART0_ISRS(tether::rpc::image::Uart);

int main() { tether::rpc::image::run_uart_device<ArmRpcService, device, kBaud>(); }
