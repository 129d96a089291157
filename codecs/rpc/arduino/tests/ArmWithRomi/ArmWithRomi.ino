// A `tether generate` library and a Tether library in one sketch: ArmRpc on Serial to the host, TetherRomi
// on a SoftwareSerial (D10 in, D11 out) to another controller. Both bundled Tether's core once, and the link
// saw its functions twice; the core is now the installed TetherCore library they both include. Built with
// arduino-builder from the ArmRpc folder and the installed Tether libraries (rpc.arduino.build.ArmWithRomi).
// Built only: on an Uno the two leave the arm's runtime too little RAM for its peak stack (a Mega has room).
#include <ArmRpc.h>
#include <ArduinoSerial.h>
#include <RomiSerial.h>
#include <SoftwareSerial.h>

using namespace romiserial;

SoftwareSerial port(10, 11);
ArduinoSerial romiPort(port);
uint16_t romiRequests = 0;

void handle_led(IRomiSerial *romiSerial, int16_t *args, const char *) {
  digitalWrite(LED_BUILTIN, args[0] == 0 ? LOW : HIGH);
  ++romiRequests;
  romiSerial->send_ok();
}

const static MessageHandler handlers[] = {{'L', 1, false, handle_led}};
RomiSerial romiSerial(romiPort, romiPort, handlers, sizeof(handlers) / sizeof(MessageHandler));

tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  reply.reached_cdeg = request.angle_cdeg;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State& next) {
  next.millis = millis();
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_SetMode(const arm_ModeRequest&, arm_ModeReply&) { return tether::rpc::Status::ok(); }

// Names the sketch; `moves` counts the requests the Romi side handled.
tether::rpc::Status Arm_Describe(const arm_DescribeRequest&, arm_Description& reply) {
  strncpy_P(reply.name, PSTR("arm-with-romi"), sizeof reply.name - 1);
  reply.moves = romiRequests;
  return tether::rpc::Status::ok();
}

ArmRpc device(Serial);

void setup() {
  pinMode(LED_BUILTIN, OUTPUT);
  Serial.begin(115200);
  port.begin(9600);
  device.begin();
}

void loop() {
  device.poll();
  romiSerial.handle_input();
}
