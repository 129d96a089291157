// TetherProxy and a `tether generate` library in one sketch: both carry the proxy's framing and the nanopb
// runtime (configured differently), so the build must stop at once with the reason, not with a page of
// redefinitions (rpc.arduino.build.ArmWithProxy).
#include <TetherProxy.h>
#include <ArmRpc.h>
#include <SoftwareSerial.h>

SoftwareSerial port(10, 11);
TetherProxy proxy(Serial);
ArmRpc device(port);

tether::rpc::Status Arm_MoveJoint(const arm_JointRequest&, arm_JointReply&) { return tether::rpc::Status::ok(); }
tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State&) { return tether::rpc::Status::ok(); }
tether::rpc::Status Arm_SetMode(const arm_ModeRequest&, arm_ModeReply&) { return tether::rpc::Status::ok(); }
tether::rpc::Status Arm_Describe(const arm_DescribeRequest&, arm_Description&) { return tether::rpc::Status::ok(); }

void setup() {
  Serial.begin(115200);
  port.begin(9600);
  proxy.begin();
  device.begin();
}

void loop() {
  proxy.poll();
  device.poll();
}
