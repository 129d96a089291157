// Bounded text builder: see tether/proxy/device/text.hpp.
#include "tether/proxy/device/text.hpp"

namespace tether {
namespace proxy {
namespace device {

TextBuilder::TextBuilder(char* buffer, size_t capacity) : buffer_(buffer), capacity_(capacity) {
  if (capacity_ != 0) buffer_[0] = '\0';
}

// Out of line: LTO inlined it into each text and number loop; Error texts are not a hot path (-52 B).
__attribute__((noinline)) void TextBuilder::put(char c) {
  if (size_ + 1 >= capacity_) {
    truncated_ = true;
    return;
  }
  buffer_[size_++] = c;
  buffer_[size_] = '\0';
}

TextBuilder& TextBuilder::text(const char* string) {
  while (*string != '\0' && !truncated_) put(*string++);
  return *this;
}

TextBuilder& TextBuilder::text(FlashText string) {
  const uint8_t* next = reinterpret_cast<const uint8_t*>(string.chars);
  for (char c = static_cast<char>(read_flash_byte(next)); c != '\0' && !truncated_;
       c = static_cast<char>(read_flash_byte(++next))) {
    put(c);
  }
  return *this;
}

namespace {

// 10^9 .. 10^1, in flash on the AVR: `number` subtracts them instead of dividing by ten (avr-gcc calls
// __udivmodsi4 for a 32-bit division, and this was its only caller in the proxy image).
const uint32_t kPowersOfTen[] TETHER_IN_FLASH = {1000000000u, 100000000u, 10000000u, 1000000u, 100000u,
                                                 10000u,      1000u,      100u,      10u};

uint32_t power_of_ten(uint8_t index) {
#if defined(__AVR__)
  return pgm_read_dword(&kPowersOfTen[index]);
#else
  return kPowersOfTen[index];
#endif
}

}  // namespace

TextBuilder& TextBuilder::number(uint32_t value) {
  char digits[10];
  uint8_t count = 0;
  for (uint8_t index = 0; index < sizeof(kPowersOfTen) / sizeof(kPowersOfTen[0]); ++index) {
    const uint32_t power = power_of_ten(index);
    char digit = '0';
    while (value >= power) {
      value -= power;
      ++digit;
    }
    if (digit != '0' || count != 0) digits[count++] = digit;  // no leading zeros
  }
  digits[count++] = static_cast<char>('0' + static_cast<char>(value));
  if (size_ + count + 1 > capacity_) {
    truncated_ = true;
    return *this;
  }
  for (uint8_t index = 0; index < count; ++index) put(digits[index]);
  return *this;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
