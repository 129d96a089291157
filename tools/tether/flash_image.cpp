#include "flash_image.hpp"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>


namespace tether::cli {

namespace {

// avr-gcc's ELF: flash at 0, SRAM from 0x800000, EEPROM from 0x810000 (physical = load addresses).
constexpr std::uint64_t kDataSpace = 0x800000;
// e_flags of an AVR ELF: the architecture in the low 7 bits; the ATmega328P is avr5.
constexpr unsigned kArchMask = 0x7F;
constexpr unsigned kArchAvr5 = 5;

std::string hex(std::uint32_t value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%04X", static_cast<unsigned>(value));
  return text;
}

// Every byte below the boot section; a segment that reaches into it (or past the 32 KiB flash) is an image
// for another part (a larger flash) or one that would overwrite the bootloader.
bool check_range(const transports::HexImage& image, const std::filesystem::path& path, std::string& error) {
  for (const auto& segment : image.segments) {
    const std::uint64_t end = std::uint64_t{segment.address} + segment.bytes.size();
    if (end > kApplicationFlashSize) {
      error = path.string() + ": not an image for an ATmega328P with optiboot: bytes at " + hex(segment.address) +
              ".." + hex(static_cast<std::uint32_t>(end - 1)) + " reach past " + hex(kApplicationFlashSize - 1) +
              " (the 32 KiB flash less the 512-byte boot section)";
      return false;
    }
  }
  if (image.size() == 0) {
    error = path.string() + ": the image has no flash contents";
    return false;
  }
  return true;
}

std::optional<transports::HexImage> read_elf(const std::filesystem::path& path, std::string& error) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    error = path.string() + ": " + std::strerror(errno);
    return std::nullopt;
  }
  struct Close {
    int fd;
    Elf* elf = nullptr;
    ~Close() {
      if (elf != nullptr) elf_end(elf);
      ::close(fd);
    }
  } guard{fd};
  if (elf_version(EV_CURRENT) == EV_NONE) {
    error = "libelf is out of date";
    return std::nullopt;
  }
  guard.elf = elf_begin(fd, ELF_C_READ, nullptr);
  GElf_Ehdr header;
  if (guard.elf == nullptr || elf_kind(guard.elf) != ELF_K_ELF || gelf_getehdr(guard.elf, &header) == nullptr) {
    error = path.string() + ": not a readable ELF file";
    return std::nullopt;
  }
  if (header.e_machine != EM_AVR) {
    error = path.string() + ": not an image for an ATmega328P: built for ELF machine " +
            std::to_string(header.e_machine) + ", not the AVR (83)";
    return std::nullopt;
  }
  if ((header.e_flags & kArchMask) != kArchAvr5) {
    error = path.string() + ": not an image for an ATmega328P: built for AVR architecture avr" +
            std::to_string(header.e_flags & kArchMask) + ", the ATmega328P is avr5";
    return std::nullopt;
  }
  // simavr's .mmcu section, when an image has one, names the part.
  std::size_t names = 0;
  if (elf_getshdrstrndx(guard.elf, &names) == 0) {
    Elf_Scn* section = nullptr;
    while ((section = elf_nextscn(guard.elf, section)) != nullptr) {
      GElf_Shdr section_header;
      if (gelf_getshdr(section, &section_header) == nullptr) continue;
      const char* name = elf_strptr(guard.elf, names, section_header.sh_name);
      if (name == nullptr || std::strcmp(name, ".mmcu") != 0) continue;
      Elf_Data* data = elf_getdata(section, nullptr);
      if (data == nullptr || data->d_buf == nullptr) continue;
      // Tag 1 (AVR_MMCU_TAG_NAME), length, then the name.
      const auto* bytes = static_cast<const std::uint8_t*>(data->d_buf);
      if (data->d_size > 2 && bytes[0] == 1) {
        const std::size_t length = std::min<std::size_t>(bytes[1], data->d_size - 2);
        const std::string mcu(reinterpret_cast<const char*>(bytes + 2), strnlen(reinterpret_cast<const char*>(bytes + 2), length));
        if (mcu != "atmega328p" && mcu != "atmega328") {
          error = path.string() + ": not an image for an ATmega328P: its .mmcu section names " + mcu;
          return std::nullopt;
        }
      }
    }
  }
  std::size_t count = 0;
  if (elf_getphdrnum(guard.elf, &count) != 0) {
    error = path.string() + ": no program headers";
    return std::nullopt;
  }
  transports::HexImage image;
  std::ifstream file(path, std::ios::binary);
  for (std::size_t i = 0; i < count; ++i) {
    GElf_Phdr segment;
    if (gelf_getphdr(guard.elf, static_cast<int>(i), &segment) == nullptr) continue;
    if (segment.p_type != PT_LOAD || segment.p_filesz == 0 || segment.p_paddr >= kDataSpace) continue;
    transports::HexImage::Segment part;
    part.address = static_cast<std::uint32_t>(segment.p_paddr);
    part.bytes.resize(segment.p_filesz);
    file.seekg(static_cast<std::streamoff>(segment.p_offset));
    file.read(reinterpret_cast<char*>(part.bytes.data()), static_cast<std::streamsize>(part.bytes.size()));
    if (!file) {
      error = path.string() + ": truncated ELF segment";
      return std::nullopt;
    }
    image.segments.push_back(std::move(part));
  }
  std::sort(image.segments.begin(), image.segments.end(),
            [](const auto& a, const auto& b) { return a.address < b.address; });
  if (!check_range(image, path, error)) return std::nullopt;
  return image;
}

std::optional<transports::HexImage> read_hex(const std::filesystem::path& path, std::string& error) {
  auto image = transports::read_intel_hex(path, error);
  if (!image || !check_range(*image, path, error)) return std::nullopt;
  return image;
}

}  // namespace

std::optional<transports::HexImage> read_flash_image(const std::filesystem::path& path, std::string& error) {
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    error = path.string() + ": " + std::strerror(errno);
    return std::nullopt;
  }
  char magic[4] = {};
  file.read(magic, sizeof magic);
  if (file.gcount() == 4 && std::memcmp(magic, "\x7F" "ELF", 4) == 0) return read_elf(path, error);
  if (file.gcount() >= 1 && magic[0] == ':') return read_hex(path, error);
  error = path.string() + ": neither an ELF image nor Intel HEX";
  return std::nullopt;
}

}  // namespace tether::cli
