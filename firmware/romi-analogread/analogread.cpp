// Romi AnalogRead on Tether: the RomiSerial README's AnalogReadSerial sketch, on the bare-metal runtime.
//
//   A -> replies [0,value], value = one 10-bit conversion of A0 (ADC0), AVcc reference (0..1023).
//
// 115200 8N1, no banner. The runtime's ADC driver (tether/firmware/adc.hpp) replaces the Arduino core's
// analogRead(A0): one conversion per request (~104 us), busy-waiting. The reply text is built with
// ArrayText instead of snprintf (which would add ~1.5 KB of flash).
#include <avr/io.h>

#include "RomiSerial.h"
#include "tether/firmware/adc.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

using namespace romiserial;

namespace {

using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;

void read_sensor(IRomiSerial* romi_serial, int16_t* args, const char* string_arg);

const MessageHandler handlers[] = {
    {'A', 0, false, read_sensor},
};

tether::romi::device::UartStream<Serial> serial;
RomiSerial romi_serial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

void read_sensor(IRomiSerial* romi, int16_t* /*args*/, const char* /*string_arg*/) {
  ArrayText<16> reply;
  reply.add_int(0).add_int(tether::firmware::adc::read(0));
  romi->send(reply.c_str());
}

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::adc::begin(0x01);  // A0
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi_serial.handle_input();
    tether::firmware::idle<Serial>();
  }
}
