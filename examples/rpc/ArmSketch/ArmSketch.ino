// examples/rpc/arm.proto's service on an Arduino Uno, as a sketch on the library `tether generate` writes:
//
//   tether generate examples/rpc/arm.proto --out ~/Arduino/libraries     # writes ~/Arduino/libraries/ArmRpc/
//
// then open this sketch in the Arduino IDE (board "Arduino Uno") and upload it; talk to it with
// `tether call --port /dev/ttyACM0 --codec rpc --schema examples/rpc/arm.proto MoveJoint joint=2 angle_cdeg=-4500`.
//
// The arm is simulated and ideal, as the bare-metal rpc-example image's: MoveJoint sets a joint's angle at
// once (errors: 1 no such joint, 2 angle outside the range, 3 the arm is on hold), Watch reports the four
// angles, the clock and the mode once per period, SetMode changes the mode (and the range) and replies the
// previous one, Describe names the arm and counts the moves. A real arm's handlers would drive its servos.
#include <ArmRpc.h>

namespace {

const uint8_t kJoints = 4;
const int32_t kMinCdeg = -18000;
const int32_t kMaxCdeg = 18000;

struct Arm {
  int32_t angles[kJoints];
  int32_t min_cdeg;
  int32_t max_cdeg;
  arm_Mode mode;
  uint32_t moves;
};
Arm arm = {{0, 0, 0, 0}, kMinCdeg, kMaxCdeg, arm_Mode_MODE_IDLE, 0};

}  // namespace

// One handler per method of the service: the request in, the reply (for Watch: the next message) out.
tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  if (request.joint >= kJoints) return tether::rpc::Status::error(1, "no joint");
  if (request.angle_cdeg < arm.min_cdeg || request.angle_cdeg > arm.max_cdeg) {
    return tether::rpc::Status::error(2, "out of range");
  }
  if (arm.mode == arm_Mode_MODE_HOLD) return tether::rpc::Status::error(3, "on hold");
  arm.angles[request.joint] = request.angle_cdeg;
  ++arm.moves;
  reply.reached_cdeg = request.angle_cdeg;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State& next) {
  next.angles_cdeg_count = kJoints;
  for (uint8_t i = 0; i < kJoints; ++i) next.angles_cdeg[i] = arm.angles[i];
  next.millis = millis();
  next.mode = arm.mode;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_SetMode(const arm_ModeRequest& request, arm_ModeReply& reply) {
  if (request.has_range) {
    const arm_ModeRequest_Range& range = request.range;
    if (range.min_cdeg > range.max_cdeg || range.min_cdeg < kMinCdeg || range.max_cdeg > kMaxCdeg) {
      return tether::rpc::Status::error(2, "out of range");
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

ArmRpc device(Serial);

void setup() {
  Serial.begin(115200);
  device.begin();  // sends ResetEvent with this boot's session id
}

void loop() {
  device.poll();
  // Other work goes here; keep each pass short (calls are answered and streams sent from poll()).
}
