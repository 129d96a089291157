// TetherRomi's Blink example (ArduinoSerial over Serial, RomiSerial, handle_input() from loop()) with the
// four handlers of the romi-bench image (a, e, c, d), for tether_avr_cycle_report: the host puts a whole
// request into Serial's receive ring, then writes a row id to GPIOR1; the next loop pass runs one
// handle_input() between two GPIOR0 writes (the row id, then 0) with interrupts held (bench/README.md).
#include <ArduinoSerial.h>
#include <RomiSerial.h>

using namespace romiserial;

void ok(IRomiSerial *romiSerial, int16_t *, const char *) { romiSerial->send_ok(); }
void values(IRomiSerial *romiSerial, int16_t *, const char *) { romiSerial->send("[0,1,2]"); }

const static MessageHandler handlers[] = {
    {'a', 0, false, ok},
    {'e', 0, false, values},
    {'c', 2, false, ok},
    {'d', 0, true, ok},
};

ArduinoSerial serial(Serial);
RomiSerial romiSerial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

void setup() {
    Serial.begin(115200);
}

void loop() {
    const uint8_t row = GPIOR1;
    if (row == 0) return;
    GPIOR1 = 0;
    cli();
    GPIOR0 = row;
    romiSerial.handle_input();
    GPIOR0 = 0;
    sei();
}
