// CPU cycles of the codecs on the ATmega328P, measured on the virtual Uno: the bench-codecs image wraps
// each operation in a pulse on its own pin, and the pulse width in simulated time (at 16 MHz) is its cost.
// Exact for this simulator (simavr counts AVR instruction cycles); the pin edges add a constant 2 cycles,
// removed with the baseline pulse on D2.
//   build/benchmarks/tether_avr_cycle_report
#include <chrono>
#include <cstdio>

#include "tether/transports/virtual_uno.hpp"

int main() {
  tether::transports::VirtualUnoOptions options;
  options.firmware = TETHER_FIRMWARE_DIR "/bench-codecs.elf";
  tether::transports::VirtualUno uno(options);
  uno.run_for(std::chrono::milliseconds(50));
  const auto cycles = [&](int pin) {
    const auto high = uno.pulse_timing(pin).high_time;
    return static_cast<double>(uno.to_cycles(high));
  };
  const double baseline = cycles(2);
  struct Row {
    int pin;
    const char* what;
    int bytes;
  };
  const Row rows[] = {
      {3, "Romi: decode + parse request #s[1234,-567]", 20},
      {4, "Romi: encode response #s[0,667]", 17},
      {5, "proxy: decode frame (ServoControl, CRC-16)", 17},
      {6, "proxy: encode frame (ServoControl, CRC-16)", 17},
      {7, "CRC-16/MCRF4XX over 64 bytes (avr-libc)", 64},
      {8, "CRC-8/SMBUS over 64 bytes (avr-libc)", 64},
  };
  std::printf("ATmega328P @ 16 MHz, avr-gcc 5.4 -Os LTO (simavr cycle counts; baseline %.0f cycles removed)\n",
              baseline);
  std::printf("%-46s %8s %10s %12s\n", "operation", "cycles", "us", "cycles/byte");
  for (const Row& row : rows) {
    const double c = cycles(row.pin) - baseline;
    std::printf("%-46s %8.0f %10.1f %12.1f\n", row.what, c, c / 16.0, c / row.bytes);
  }
  return 0;
}
