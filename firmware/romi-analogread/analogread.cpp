// Romi AnalogRead on Tether: the RomiSerial README's AnalogReadSerial sketch, on the bare-metal runtime.
//
//   A -> replies [0,value], value = one 10-bit conversion of A0 (ADC0), AVcc reference (0..1023).
//
// 115200 8N1, no banner. The ADC code replaces the Arduino core's analogRead(A0): AVcc reference
// (REFS0), channel 0, prescaler 128 (125 kHz ADC clock at 16 MHz, within the 50..200 kHz of full
// resolution), one conversion per request (~112 us), busy-waiting on ADSC. The reply text is built with
// ArrayText instead of snprintf (which would add ~1.5 KB of flash).
#include <avr/io.h>

#include "RomiSerial.h"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

using namespace romiserial;

namespace {

using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;

void adc_init() {
  ADMUX = _BV(REFS0);                                        // AVcc reference, right-adjusted, ADC0
  ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);  // enabled, clock / 128
  DIDR0 = _BV(ADC0D);                                        // A0's digital input buffer off
}

uint16_t analog_read_a0() {
  ADMUX = _BV(REFS0);  // channel 0 (kept explicit: another channel could have been selected)
  ADCSRA = static_cast<uint8_t>(ADCSRA | _BV(ADSC));
  while ((ADCSRA & _BV(ADSC)) != 0) {
  }
  return ADC;  // ADCL then ADCH, as the data sheet requires
}

void read_sensor(IRomiSerial* romi_serial, int16_t* args, const char* string_arg);

const MessageHandler handlers[] = {
    {'A', 0, false, read_sensor},
};

tether::romi::device::UartStream<Serial> serial;
RomiSerial romi_serial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

void read_sensor(IRomiSerial* romi, int16_t* /*args*/, const char* /*string_arg*/) {
  ArrayText<16> reply;
  reply.add_int(0).add_int(analog_read_a0());
  romi->send(reply.c_str());
}

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  adc_init();
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi_serial.handle_input();
    tether::firmware::idle<Serial>();
  }
}
