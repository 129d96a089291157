// Peak stack of a firmware image on the virtual Uno: paints the free SRAM between the end of the static
// data and the stack with a pattern; what the pattern lost later is what the stack reached. 64 bytes below
// the current stack pointer are left alone: an interrupt handler may be using them at this quantum
// boundary. Interrupt handlers that ran meanwhile are in the figure: they use the stack they find.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "tether/transports/virtual_uno.hpp"

namespace tether::testing {

inline constexpr std::uint8_t kStackPaint = 0xA5;
inline constexpr std::uint16_t kStackPointerAddress = 0x5D;  // SPL, SPH in the data space

/// The first byte after the static data: avr-libc's __heap_start when the image references it, else the
/// end of .noinit or .bss (the linker script defines those only when used, too).
inline std::uint16_t heap_start(const transports::VirtualUno& board) {
  for (const char* name : {"__heap_start", "__noinit_end", "__bss_end"}) {
    if (const auto symbol = board.symbol(name)) return static_cast<std::uint16_t>(symbol->address);
  }
  throw std::runtime_error("the image has none of __heap_start, __noinit_end, __bss_end");
}

/// Paints the free SRAM from `heap_start` to 64 bytes below the stack pointer.
inline void paint_free_sram(transports::VirtualUno& board) {
  const std::vector<std::uint8_t> sp = board.read_memory(kStackPointerAddress, 2);
  const auto stack_pointer = static_cast<std::uint16_t>(sp[0] | (sp[1] << 8));
  const std::uint16_t from = heap_start(board);
  board.write_memory(from, std::vector<std::uint8_t>(static_cast<std::size_t>(stack_pointer - 64 - from), kStackPaint));
}

/// Bytes of stack used at the deepest point since `paint_free_sram` (RAMEND down to the lowest byte touched).
inline std::size_t peak_stack(const transports::VirtualUno& board) {
  const std::uint16_t from = heap_start(board);
  const std::vector<std::uint8_t> ram =
      board.read_memory(from, static_cast<std::size_t>(transports::atmega328p::kRamEnd + 1 - from));
  std::size_t untouched = 0;
  while (untouched < ram.size() && ram[untouched] == kStackPaint) ++untouched;
  return ram.size() - untouched;
}

/// SRAM bytes neither static data nor ever stack since `paint_free_sram`.
inline std::size_t never_used_sram(const transports::VirtualUno& board) {
  return transports::atmega328p::kRamEnd + 1u - heap_start(board) - peak_stack(board);
}

}  // namespace tether::testing
