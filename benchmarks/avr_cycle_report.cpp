// CPU cycles of the codecs on the ATmega328P, measured on the virtual Uno: the bench-codecs image wraps
// each operation in a pulse on its own pin, and the pulse width in simulated time (at 16 MHz) is its cost.
// Exact for this simulator (simavr counts AVR instruction cycles); the pin edges add a constant 2 cycles,
// removed with the baseline pulse on D2. The bytes each operation reads or writes come from the image
// (`bench_wire_bytes`, filled from the encoders' results), not from this file.
//   build/benchmarks/tether_avr_cycle_report
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <vector>

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
  const auto symbol = uno.symbol("bench_wire_bytes");
  if (!symbol || symbol->space != tether::transports::FirmwareSymbol::Space::data || symbol->size < 20) {
    std::fprintf(stderr, "bench-codecs.elf has no bench_wire_bytes[20] in SRAM: rebuild the firmware\n");
    return 1;
  }
  const std::vector<std::uint8_t> wire_bytes = uno.read_memory(static_cast<std::uint16_t>(symbol->address), 20);
  const double baseline = cycles(2);
  struct Row {
    int pin;  // Arduino pin: D0..D13, then A0..A5 as 14..19
    const char* what;
  };
  const Row rows[] = {
      {3, "Romi: decode + parse request #s[1234,-567]"},
      {4, "Romi: encode response #s[0,667]"},
      {5, "proxy: decode frame (ServoControl, CRC-16)"},
      {6, "proxy: encode frame (ServoControl, CRC-16)"},
      {7, "CRC-16/MCRF4XX over 64 bytes (avr-libc)"},
      {8, "CRC-8/SMBUS over 64 bytes (avr-libc)"},
      {9, "Elcano B: read drive D{s 50}{a 25}"},
      {10, "Elcano D: read drive D{s50}{a25}74"},
      {11, "Elcano B: read segment X{n 4}...{p 3200,-64000}"},
      {12, "Elcano D: read segment X{n4}...{q-64000}243"},
      {13, "Elcano B: write drive"},
      {14, "Elcano D: write drive"},
      {15, "Elcano B: write segment"},
      {16, "Elcano D: write segment"},
      {17, "Elcano B: RingNode feed + forward drive"},
      {18, "Elcano D: RingNode feed + forward drive"},
      {19, "Elcano B: RingNode feed + capture drive"},
  };
  std::printf("ATmega328P @ 16 MHz, avr-gcc 5.4 -Os LTO (simavr cycle counts; baseline %.0f cycles removed)\n",
              baseline);
  std::printf("%-50s %6s %8s %8s %12s\n", "operation", "bytes", "cycles", "us", "cycles/byte");
  int status = 0;
  for (const Row& row : rows) {
    const unsigned bytes = wire_bytes[static_cast<std::size_t>(row.pin)];
    if (uno.pulse_timing(row.pin).edges < 2 || bytes == 0) {
      std::printf("%-50s   (no pulse: the image did not run this operation)\n", row.what);
      status = 1;
      continue;
    }
    const double c = cycles(row.pin) - baseline;
    std::printf("%-50s %6u %8.0f %8.1f %12.1f\n", row.what, bytes, c, c / 16.0, c / bytes);
  }
  return status;
}
