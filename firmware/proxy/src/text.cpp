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
  const char* next = string.chars;
#if defined(__AVR__)
  for (char c = static_cast<char>(pgm_read_byte(next)); c != '\0' && !truncated_;
       c = static_cast<char>(pgm_read_byte(++next))) {
    put(c);
  }
#else
  text(next);
#endif
  return *this;
}

TextBuilder& TextBuilder::number(uint32_t value) {
  char digits[10];
  uint8_t count = 0;
  do {
    digits[count++] = static_cast<char>('0' + static_cast<char>(value % 10u));
    value /= 10u;
  } while (value != 0);
  if (size_ + count + 1 > capacity_) {
    truncated_ = true;
    return *this;
  }
  while (count != 0) put(digits[--count]);
  return *this;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
