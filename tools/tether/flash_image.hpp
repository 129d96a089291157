// The flash contents of an ATmega328P image read from an avr-gcc ELF or an Intel HEX file, checked before
// anything talks to a board (`tether flash`).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "tether/transports/intel_hex.hpp"

namespace tether::cli {

/// File name, in the firmware folder, of the optiboot the AVR sub-build makes from Debian's arduino-core-avr
/// source (firmware/CMakeLists.txt says why not Debian's own hex): 115200 baud, 1 s timeout, flash only (no
/// EEPROM over STK500).
inline constexpr const char* kOptibootImage = "optiboot-atmega328.hex";

/// Flash bytes an upload through optiboot may write: 32 KiB less its 512-byte boot section.
inline constexpr std::uint32_t kApplicationFlashSize = 0x7E00;

/// Reads `path` (ELF by its magic, else Intel HEX) and checks it is an application for the ATmega328P: an
/// ELF must be for the AVR (e_machine 83) in the avr5 family (e_flags), with an `.mmcu` section, if any,
/// naming atmega328p; every byte must lie below the boot section (kApplicationFlashSize). nullopt with
/// `error` naming the file and the problem otherwise.
std::optional<transports::HexImage> read_flash_image(const std::filesystem::path& path, std::string& error);

}  // namespace tether::cli
