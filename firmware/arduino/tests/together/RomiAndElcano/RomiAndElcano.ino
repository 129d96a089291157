// Two Tether libraries in one sketch, as a user with a Romi link to the host and an Elcano ring on another
// port writes it: TetherRomi on Serial (the Blink handler and one that reports the ring), TetherElcano's
// node on a SoftwareSerial (D10 in, D11 out). Both bundled Tether's core once, and the link saw its
// functions twice; the core is now the TetherCore library they both include. Built with arduino-builder as
// docs/arduino.md tells users (arduino.build.together.RomiAndElcano), run on the virtual Uno
// (arduino.TetherTogether.*).
#include <ArduinoSerial.h>
#include <RomiSerial.h>
#include <ElcanoSerial.h>
#include <SoftwareSerial.h>

using namespace romiserial;

void handle_led(IRomiSerial *romiSerial, int16_t *args, const char *string_arg);
void handle_ring(IRomiSerial *romiSerial, int16_t *args, const char *string_arg);

const static MessageHandler handlers[] = {
    { 'L', 1, false, handle_led },
    { 'R', 0, false, handle_ring },
};

ArduinoSerial serial(Serial);
RomiSerial romiSerial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

SoftwareSerial ring(10, 11);
elcano::ParseState ps;
elcano::SerialData dt;
int16_t drives = 0;
int16_t last_outcome = -1;

void setup() {
    pinMode(LED_BUILTIN, OUTPUT);
    Serial.begin(115200);
    ring.begin(9600);
    ps.dt = &dt;
    ps.input = &ring;
    ps.output = &ring;
    ps.capture = elcano::MsgType::drive;
    dt.clear();
}

void loop() {
    romiSerial.handle_input();
    elcano::ParseStateError r = ps.update();
    last_outcome = static_cast<int16_t>(r);
    if (r == elcano::ParseStateError::success) ++drives;
}

void handle_led(IRomiSerial *romiSerial, int16_t *args, const char *)
{
    digitalWrite(LED_BUILTIN, args[0] == 0 ? LOW : HIGH);
    romiSerial->send_ok();
}

// "#R": [0, drives captured from the ring, the node's last outcome] (nothing on the ring: unavailable).
void handle_ring(IRomiSerial *romiSerial, int16_t *, const char *)
{
    ArrayText<24> reply;
    reply.add_int(0).add_int(drives).add_int(last_outcome);
    romiSerial->send(reply.c_str());
}
