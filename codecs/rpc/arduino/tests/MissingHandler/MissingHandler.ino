// A sketch on the ArmRpc library that forgets Arm_Describe: its build must fail at the link, naming the
// handler (rpc.arduino.build.MissingHandler).
#include <ArmRpc.h>

tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  reply.reached_cdeg = request.angle_cdeg;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State&) { return tether::rpc::Status::ok(); }

tether::rpc::Status Arm_SetMode(const arm_ModeRequest&, arm_ModeReply&) { return tether::rpc::Status::ok(); }

ArmRpc device(Serial);

void setup() {
  Serial.begin(115200);
  device.begin();
}

void loop() { device.poll(); }
