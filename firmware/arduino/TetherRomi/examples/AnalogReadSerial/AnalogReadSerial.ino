// AnalogReadSerial over the Romi protocol: "#A:xxxx" answers [0,<analogRead(A0)>].
// The RomiSerial README's sketch, with the reply built by ArrayText instead of snprintf (snprintf works
// too, at ~1.5 KB of flash more).
#include <ArduinoSerial.h>
#include <RomiSerial.h>

using namespace romiserial;

ArduinoSerial serial(Serial);

void read_sensor(IRomiSerial *romiSerial, int16_t *args, const char *string_arg);

const static MessageHandler handlers[] = {
    { 'A', 0, false, read_sensor },
};

RomiSerial romiSerial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

void setup() {
    Serial.begin(115200);
}

void loop() {
    romiSerial.handle_input();
}

void read_sensor(IRomiSerial *romiSerial, int16_t *args, const char *string_arg)
{
    ArrayText<16> reply;
    reply.add_int(0).add_int(analogRead(A0));
    romiSerial->send(reply.c_str());
}
