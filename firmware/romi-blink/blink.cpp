// Romi Blink on Tether: the RomiSerial README's Blink sketch, on the bare-metal runtime.
//
//   L[n] -> drives the LED pin (Uno D13 = PB5) low for n == 0, high otherwise; replies [0].
//
// 115200 8N1, no banner. The handler code is the sketch's, written against the RomiSerial API
// (RomiSerial.h); only the stream (UartStream over Uart0 instead of ArduinoSerial over Serial) and the
// pin access (registers instead of digitalWrite) differ.
#include <avr/io.h>

#include "RomiSerial.h"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

using namespace romiserial;

namespace {

// A request is at most 66 bytes and the host waits for each response; 128 bytes of RX absorb a host
// that sends the next request (or garbage) while a reply is still going out.
using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;

void handle_led(IRomiSerial* romi_serial, int16_t* args, const char* string_arg);

const MessageHandler handlers[] = {
    {'L', 1, false, handle_led},
};

tether::romi::device::UartStream<Serial> serial;
RomiSerial romi_serial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

void handle_led(IRomiSerial* romi, int16_t* args, const char* /*string_arg*/) {
  if (args[0] == 0) {
    PORTB = static_cast<uint8_t>(PORTB & ~_BV(PORTB5));
  } else {
    PORTB = static_cast<uint8_t>(PORTB | _BV(PORTB5));
  }
  romi->send_ok();
}

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  DDRB = static_cast<uint8_t>(DDRB | _BV(DDB5));  // LED pin as output, low
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi_serial.handle_input();
    tether::firmware::idle<Serial>();  // wakes on a byte or the 1 ms tick (request deadline)
  }
}
