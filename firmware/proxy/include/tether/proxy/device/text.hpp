/// @file text.hpp
/// A bounded text builder for the short messages a device sends (Error.text), without printf.
///
/// avr-libc's printf family costs ~1.5 KB of flash; a device only needs words and unsigned numbers. The
/// builder writes into a caller's buffer, always NUL-terminated, and truncates instead of overflowing.
#pragma once

#include <stddef.h>
#include <stdint.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#endif

namespace tether {
namespace proxy {
namespace device {

/// Puts a `const char[]` in flash on the AVR (`PROGMEM`; nothing on the host): avr-gcc otherwise copies
/// every string into RAM at boot (the proxy image's messages took ~220 B of the Uno's 2 KB). Named
/// arrays, not `PSTR`: avr-gcc 5.4's LTO crashes on `PSTR` here.
#if defined(__AVR__)
#define TETHER_IN_FLASH PROGMEM
#else
#define TETHER_IN_FLASH
#endif

/// A NUL-terminated string declared `TETHER_IN_FLASH` (read with pgm_read_byte on the AVR).
struct FlashText {
  const char* chars;  ///< The string, in program memory on the AVR.
};

/// Reads a byte of an object declared `TETHER_IN_FLASH` (`pgm_read_byte` on the AVR).
inline uint8_t read_flash_byte(const uint8_t* address) {
#if defined(__AVR__)
  return pgm_read_byte(address);
#else
  return *address;
#endif
}

/// Appends text and numbers to `buffer[0..capacity)` (capacity includes the NUL).
class TextBuilder {
 public:
  /// Builder over `buffer` of `capacity` bytes (>= 1), which it empties.
  TextBuilder(char* buffer, size_t capacity);
  /// Appends a NUL-terminated string (what fits).
  TextBuilder& text(const char* string);
  /// Appends a string kept in flash (what fits).
  TextBuilder& text(FlashText string);
  /// Appends `value` in decimal (all digits, or nothing if they do not all fit).
  TextBuilder& number(uint32_t value);
  /// Characters written (the NUL excluded).
  size_t size() const { return size_; }
  /// True when something did not fit.
  bool truncated() const { return truncated_; }

 private:
  void put(char c);

  char* buffer_;
  size_t capacity_;
  size_t size_ = 0;
  bool truncated_ = false;
};

}  // namespace device
}  // namespace proxy
}  // namespace tether
