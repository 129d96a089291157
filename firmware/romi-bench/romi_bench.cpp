// Romi bench image: the 4-handler device of issue 17 (a, e, c, d; romi_bench_handlers.hpp) on Tether's
// own UART driver, 115200 8N1, no banner. benchmarks/avr_cycle_report.cpp runs it in a closed loop on
// the virtual Uno (turnaround, calls/s against the wire bound) and reports its flash and static RAM.
#include "romi_bench_handlers.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

namespace {

// The device reads each byte as it arrives and a Romi host waits for each response, so the RX ring only
// holds what comes while a reply waits for room in the TX ring (a re-send: at most a 66-byte request);
// a full TX ring makes write() sleep until the UART, the bottleneck anyway, takes a byte.
using Serial = tether::firmware::Uart0<64, 32>;
constexpr uint32_t kBaud = 115200;

tether::romi::device::UartStream<Serial> serial;
romiserial::RomiSerial romi(serial, serial, romi_bench::kHandlers, romi_bench::kHandlerCount);

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi.handle_input();
    tether::firmware::idle<Serial>();
  }
}
