// Compile-only check (never linked into an image): instantiates every runtime template with the
// extreme ring sizes, so avr-gcc and -Werror see every member function, not only those an image calls.
#include "tether/firmware/runtime.hpp"

namespace tether {
namespace firmware {

static_assert(uart_baud_setting(16000000u, 115200u).double_speed, "115200 at 16 MHz: U2X0=1");
static_assert(uart_baud_setting(16000000u, 115200u).ubrr == 16, "115200 at 16 MHz: UBRR0=16");
static_assert(!uart_baud_setting(16000000u, 57600u).double_speed, "57600: the Uno bridge's divisor");
static_assert(uart_baud_setting(16000000u, 57600u).ubrr == 16, "57600 at 16 MHz: UBRR0=16");
static_assert(uart_baud_setting(16000000u, 9600u).ubrr == 103, "9600 at 16 MHz: UBRR0=103, U2X0=0");
static_assert(uart_baud_setting(16000000u, 1000000u).ubrr == 0, "1 Mbit/s: exact both ways, tie to U2X0=0");
static_assert(uart_baud_setting(16000000u, 300u).ubrr == 3332, "300 bit/s: UBRR0=3332 (U2X0=0)");

template class Uart0<2, 2>;
template class Uart0<64, 64>;
template class Uart0<256, 256>;
template void idle<Uart0<2, 2>>();
template void runtime_init<Uart0<256, 256>>(uint32_t);

}  // namespace firmware
}  // namespace tether
