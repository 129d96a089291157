#include "simavr_glue.hpp"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <unistd.h>

#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <system_error>

#include "tether/transports/intel_hex.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::transports {

namespace {

class VirtualUnoCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "virtual_uno"; }
  std::string message(int code) const override {
    switch (static_cast<VirtualUnoError>(code)) {
      case VirtualUnoError::not_an_avr_elf:
        return "not an AVR ELF image";
      case VirtualUnoError::firmware_too_large:
        return "image does not fit the ATmega328P's 32 KiB flash";
      case VirtualUnoError::simulator_failed:
        return "libsimavr could not create the MCU";
      case VirtualUnoError::bad_bootloader:
        return "not a bootloader for the ATmega328P's boot section";
    }
    return "unknown virtual_uno error";
  }
  std::error_condition default_error_condition(int code) const noexcept override {
    switch (static_cast<VirtualUnoError>(code)) {
      case VirtualUnoError::not_an_avr_elf:
        return std::errc::executable_format_error;
      case VirtualUnoError::firmware_too_large:
        return std::errc::file_too_large;
      case VirtualUnoError::simulator_failed:
        return std::errc::not_enough_memory;
      case VirtualUnoError::bad_bootloader:
        return std::errc::executable_format_error;
    }
    return std::error_condition(code, *this);
  }
};

}  // namespace

const std::error_category& virtual_uno_category() {
  static const VirtualUnoCategory category;
  return category;
}

std::error_code make_error_code(VirtualUnoError error) {
  return {static_cast<int>(error), virtual_uno_category()};
}

namespace detail {

namespace {

// libelf's elf_version() and simavr's loader are not meant to run concurrently.
std::mutex& loader_mutex() {
  static std::mutex mutex;
  return mutex;
}

int log_threshold() {
  static const int threshold = [] {
    const char* text = std::getenv("TETHER_SIMAVR_LOG");
    return text != nullptr ? std::atoi(text) : 0;
  }();
  return threshold;
}

void quiet_logger(avr_t* /*avr*/, const int level, const char* format, va_list arguments) {
  if (level <= log_threshold()) {
    std::vfprintf(stderr, format, arguments);
  }
}

[[noreturn]] void fail(std::error_code code, const std::filesystem::path& path, const std::string& what) {
  throw std::system_error(code, "virtual Uno: " + path.string() + ": " + what);
}

struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

struct ElfHandle {
  Elf* elf = nullptr;
  ~ElfHandle() {
    if (elf != nullptr) elf_end(elf);
  }
};

constexpr std::uint64_t kFlashSize = 32 * 1024;

// avr-gcc's ELF address spaces: flash from 0, SRAM (data space) from 0x800000, EEPROM from 0x810000.
constexpr std::uint64_t kDataBase = 0x800000;
constexpr std::uint64_t kEepromBase = 0x810000;
constexpr std::uint64_t kSpaceEnd = 0x820000;

FirmwareSymbol to_firmware_symbol(const GElf_Sym& symbol) {
  FirmwareSymbol result;
  const std::uint64_t value = symbol.st_value;
  if (value >= kEepromBase && value < kSpaceEnd) {
    result.space = FirmwareSymbol::Space::eeprom;
    result.address = static_cast<std::uint32_t>(value - kEepromBase);
  } else if (value >= kDataBase && value < kEepromBase) {
    result.space = FirmwareSymbol::Space::data;
    result.address = static_cast<std::uint32_t>(value - kDataBase);
  } else {
    result.space = FirmwareSymbol::Space::flash;
    result.address = static_cast<std::uint32_t>(value);
  }
  result.size = static_cast<std::uint32_t>(symbol.st_size);
  return result;
}

// Everything elf_read_firmware() relies on without checking, so that a bad file is an error, not a crash.
// Collects the named symbols into `table` when given (a global one replaces a local one of that name).
void validate_elf(const std::filesystem::path& path, SymbolTable* table) {
  FileDescriptor file;
  file.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (file.fd < 0) fail(std::error_code(errno, std::generic_category()), path, "cannot open the image");
  unsigned char ident[EI_NIDENT] = {};
  const ssize_t got = ::read(file.fd, ident, sizeof ident);
  if (got < 0) fail(std::error_code(errno, std::generic_category()), path, "cannot read the image");
  const std::error_code bad = make_error_code(VirtualUnoError::not_an_avr_elf);
  if (got != static_cast<ssize_t>(sizeof ident) || std::memcmp(ident, ELFMAG, SELFMAG) != 0) {
    fail(bad, path, "not an ELF file");
  }
  if (ident[EI_CLASS] != ELFCLASS32 || ident[EI_DATA] != ELFDATA2LSB) fail(bad, path, "not a 32-bit little-endian ELF");

  ElfHandle handle;
  handle.elf = elf_begin(file.fd, ELF_C_READ, nullptr);
  if (handle.elf == nullptr || elf_kind(handle.elf) != ELF_K_ELF) fail(bad, path, "libelf cannot parse it");
  GElf_Ehdr header;
  if (gelf_getehdr(handle.elf, &header) == nullptr) fail(bad, path, "no ELF header");
  if (header.e_machine != EM_AVR) {
    fail(bad, path, "built for ELF machine " + std::to_string(header.e_machine) + ", not the AVR (83)");
  }
  size_t names = 0;
  if (elf_getshdrstrndx(handle.elf, &names) != 0) fail(bad, path, "no section name table");

  std::uint64_t flash = 0;
  bool has_text = false;
  std::uint64_t base = 0;
  Elf_Scn* section = nullptr;
  while ((section = elf_nextscn(handle.elf, section)) != nullptr) {
    GElf_Shdr section_header;
    if (gelf_getshdr(section, &section_header) == nullptr) fail(bad, path, "unreadable section header");
    const char* name = elf_strptr(handle.elf, names, section_header.sh_name);
    if (name == nullptr) fail(bad, path, "unreadable section name");
    const std::string section_name(name);
    const bool loaded = section_name == ".text" || section_name == ".data";
    if (loaded || section_name == ".bss" || section_name == ".mmcu" || section_name == ".eeprom" ||
        section_name == ".fuse" || section_name == ".lock") {
      if (elf_getdata(section, nullptr) == nullptr) fail(bad, path, "section " + section_name + " has no data");
    }
    if (loaded) flash += section_header.sh_size;
    if (section_name == ".text") has_text = true;
    if (section_header.sh_type == SHT_SYMTAB) {
      if (section_header.sh_entsize == 0) fail(bad, path, "malformed symbol table");
      Elf_Data* symbols = elf_getdata(section, nullptr);
      if (symbols == nullptr) fail(bad, path, "unreadable symbol table");
      const std::uint64_t count = section_header.sh_size / section_header.sh_entsize;
      for (std::uint64_t i = 0; i < count; ++i) {
        GElf_Sym symbol;
        if (gelf_getsym(symbols, static_cast<int>(i), &symbol) == nullptr) fail(bad, path, "unreadable symbol");
        const char* symbol_name = elf_strptr(handle.elf, section_header.sh_link, symbol.st_name);
        if (symbol_name == nullptr) fail(bad, path, "unreadable symbol name");
        if (std::strcmp(symbol_name, "__vectors") == 0) base = symbol.st_value;
        const int type = GELF_ST_TYPE(symbol.st_info);
        if (table != nullptr && symbol_name[0] != '\0' && type != STT_SECTION && type != STT_FILE) {
          const bool global = GELF_ST_BIND(symbol.st_info) != STB_LOCAL;
          const auto [entry, added] = table->try_emplace(symbol_name, to_firmware_symbol(symbol));
          if (!added && global) entry->second = to_firmware_symbol(symbol);
        }
      }
    }
  }
  if (!has_text) fail(bad, path, "no .text section");
  if (base + flash > kFlashSize) {
    fail(make_error_code(VirtualUnoError::firmware_too_large), path,
         std::to_string(flash) + " bytes of .text + .data at " + std::to_string(base) + " do not fit 32768 bytes of flash");
  }
}

void free_firmware(elf_firmware_t& firmware) {
  std::free(firmware.flash);
  std::free(firmware.eeprom);
  std::free(firmware.fuse);
  std::free(firmware.lockbits);
#if ELF_SYMBOLS
  for (std::uint32_t i = 0; i < firmware.symbolcount; ++i) std::free(firmware.symbol[i]);
  std::free(firmware.symbol);
#endif
}

}  // namespace

void install_quiet_logger() {
  static std::once_flag once;
  std::call_once(once, [] { avr_global_logger_set(quiet_logger); });
}

avr_t* load_avr(const std::filesystem::path& path, std::uint32_t frequency_hz, SymbolTable* symbols) {
  install_quiet_logger();
  std::lock_guard lock(loader_mutex());
  if (path.empty()) {  // a blank application flash (a board that only has a bootloader)
    avr_t* avr = avr_make_mcu_by_name("atmega328p");
    if (avr == nullptr) fail(make_error_code(VirtualUnoError::simulator_failed), "(no image)", "no atmega328p in libsimavr");
    if (avr_init(avr) != 0) {
      std::free(avr);
      fail(make_error_code(VirtualUnoError::simulator_failed), "(no image)", "avr_init failed");
    }
    avr->frequency = frequency_hz;
    avr->vcc = avr->avcc = avr->aref = 5000;
    return avr;
  }
  if (elf_version(EV_CURRENT) == EV_NONE) fail(make_error_code(VirtualUnoError::simulator_failed), path, "libelf is out of date");
  validate_elf(path, symbols);

  // Zero-initialised, so fields a differently configured libsimavr does not touch stay null for free_firmware().
  auto* firmware = static_cast<elf_firmware_t*>(std::calloc(1, sizeof(elf_firmware_t)));
  if (firmware == nullptr) throw std::bad_alloc();
  struct Release {
    elf_firmware_t* firmware;
    ~Release() {
      free_firmware(*firmware);
      std::free(firmware);
    }
  } release{firmware};
  if (elf_read_firmware(path.c_str(), firmware) != 0) {
    fail(make_error_code(VirtualUnoError::not_an_avr_elf), path, "libsimavr could not read the image");
  }
  firmware->tracecount = 0;  // never let an image's .mmcu section make simavr write a VCD file

  avr_t* avr = avr_make_mcu_by_name("atmega328p");
  if (avr == nullptr) fail(make_error_code(VirtualUnoError::simulator_failed), path, "no atmega328p in libsimavr");
  if (avr_init(avr) != 0) {
    std::free(avr);
    fail(make_error_code(VirtualUnoError::simulator_failed), path, "avr_init failed");
  }
  avr_load_firmware(avr, firmware);
  avr->frequency = frequency_hz;
  if (avr->vcc == 0) avr->vcc = 5000;
  if (avr->avcc == 0) avr->avcc = 5000;
  if (avr->aref == 0) avr->aref = 5000;
  return avr;
}

void load_bootloader(avr_t* avr, const std::filesystem::path& path) {
  const std::error_code bad = make_error_code(VirtualUnoError::bad_bootloader);
  if (::access(path.c_str(), R_OK) != 0) fail(std::error_code(errno, std::generic_category()), path, "cannot read the bootloader");
  std::string problem;
  const auto image = read_intel_hex(path, problem);
  if (!image) throw std::system_error(bad, "virtual Uno: " + problem);
  if (image->size() == 0) fail(bad, path, "no data");
  const std::uint32_t flash_size = avr->flashend + 1;
  if (image->end() > flash_size) {
    char where[64];
    std::snprintf(where, sizeof where, "data up to 0x%X", static_cast<unsigned>(image->end() - 1));
    fail(bad, path, std::string(where) + " lies outside the 32 KiB flash");
  }
  for (const auto& segment : image->segments) std::memcpy(avr->flash + segment.address, segment.bytes.data(), segment.bytes.size());
  const std::uint32_t start = image->begin();
  // The boot section of the ATmega328P starts at 0x3800, 0x3C00, 0x3E00 or 0x3F00 (words): BOOTSZ.
  if (start != 0x7000 && start != 0x7800 && start != 0x7C00 && start != 0x7E00) {
    fail(bad, path, "does not start at a boot section address (0x7000, 0x7800, 0x7C00 or 0x7E00)");
  }
  // BOOTRST programmed: every reset starts the bootloader; the whole flash is code (the application the
  // bootloader writes with SPM included).
  avr->reset_pc = start;
  avr->pc = start;
  avr->codeend = avr->flashend;
}

void destroy_avr(avr_t* avr) {
  if (avr == nullptr) return;
  avr_terminate(avr);
  std::free(avr);
}

}  // namespace detail
}  // namespace tether::transports

#if defined(__SANITIZE_ADDRESS__)
// libsimavr 1.6's avr_terminate() does not free the IRQ pool, the names of the interrupt-vector IRQs nor
// the hooks registered on them (a few kB per simulated MCU). Tell LeakSanitizer to ignore allocations made
// inside libsimavr so sanitized test runs report only our own leaks. Weak: another library may also
// provide suppressions.
extern "C" __attribute__((weak, used)) const char* __lsan_default_suppressions() {
  return "leak:libsimavr.so\n";
}
#endif
