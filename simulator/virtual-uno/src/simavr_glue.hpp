// Internal: loading an image into a fresh libsimavr ATmega328P, the quiet logger, the error category.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <unordered_map>

// libsimavr's headers (C, with their own extern "C"); included as system headers (see CMakeLists.txt).
#include <avr_adc.h>
#include <avr_eeprom.h>
#include <avr_ioport.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_irq.h>

#include "tether/transports/virtual_uno.hpp"

namespace tether::transports::detail {

/// Routes simavr's log output to stderr only when TETHER_SIMAVR_LOG=<level> (1 output .. 5 debug) is set;
/// silent otherwise (simavr prints "Loaded ..." and UART lines to stdout by default). Idempotent.
void install_quiet_logger();

/// The image's named symbols (section symbols and file names left out), by name.
using SymbolTable = std::unordered_map<std::string, FirmwareSymbol>;

/// An empty `path` gives a blank flash (erased: 0xFF). Otherwise validates `path` as an AVR ELF that fits the ATmega328P, creates an atmega328p, initialises it at
/// `frequency_hz` and loads the image; `symbols` (when given) receives its symbol table. Throws
/// std::system_error (OS errors from open/read, VirtualUnoError otherwise) with a message naming the
/// file. The result is released with `destroy_avr`.
avr_t* load_avr(const std::filesystem::path& path, std::uint32_t frequency_hz, SymbolTable* symbols = nullptr);

/// Writes the Intel HEX bootloader at `path` into `avr`'s flash and points the reset vector at its first
/// address (the BOOTRST fuse programmed). Throws std::system_error (VirtualUnoError::bad_bootloader for data
/// outside the flash or not at a boot-section start).
void load_bootloader(avr_t* avr, const std::filesystem::path& path);

/// avr_terminate + free.
void destroy_avr(avr_t* avr);

}  // namespace tether::transports::detail
