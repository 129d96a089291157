// Romi bench image: the 4-handler device (a, e, c, d; romi_bench_handlers.hpp) on Tether's
// own UART driver, 115200 8N1, no banner. benchmarks/avr_cycle_report.cpp runs it in a closed loop on
// the virtual Uno (turnaround, calls/s against the wire bound) and reports its flash and static RAM.
#include "romi_bench_handlers.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

namespace {

// UART rings sized by the protocol, not by habit (static RAM is the Uno's scarcest resource):
//  - RX 8: the device copies each byte into its 42-byte frame buffer as soon as the main loop sees it,
//    so the ring only bridges the stretches in which the loop does not read. Within a request the
//    longest is the frame's '\r' (CRC check and parse); a whole `#d["Hello there"]` request, all its
//    bytes and its reply included, costs 4054 cycles (cycle report), under 3 byte times at 115200
//    (1389 cycles each), and the UART's own 2-byte FIFO comes on top. Between a
//    request's '\n' and the end of its reply a Romi host sends nothing (it waits for the reply; Tether
//    hosts re-send only after an error reply or, when asked, after the 1 s attempt timeout, and these
//    handlers answer in microseconds). A byte that still finds the ring full is counted
//    (`UartCounters::rx_overflows`) and its frame answered with an error (-1..-7, or -30 when its end
//    was lost).
//  - TX 8: write() sleeps while the ring is full, until the UART (the bottleneck anyway) takes a byte;
//    a bigger ring only frees the loop earlier during a reply, when nothing is coming in.
// Measured (tether_avr_cycle_report, closed loop of #e): 64/32 and 8/8 both run at 99.0 % of the wire
// bound with the same turnaround (median 312 cycles); 8/8 is 80 B of RAM less.
using Serial = tether::firmware::Uart0<8, 8>;
constexpr uint32_t kBaud = 115200;

tether::romi::device::UartStream<Serial> serial;
// The device sized to the four handlers (romi_serial.hpp, "Sizing a device"): the longest request is d's
// with a 32-character string, 37 payload characters (`d["..."]`); the longest reply e's `#e[0,1,2]:iicc\r\n`,
// 16 bytes. 223 bytes of RAM, against RomiSerial's 321; a longer request is answered -1 (too long).
romiserial::BasicRomiSerial<37, 16> romi(serial, serial, romi_bench::kHandlers, romi_bench::kHandlerCount);

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi.handle_input();
    tether::firmware::idle<Serial>();
  }
}
