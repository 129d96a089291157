// JSON array text for handler replies (array_text.hpp).
#include "tether/romi/device/array_text.hpp"

#include <string.h>

namespace tether {
namespace romi {
namespace device {

uint8_t format_decimal(int32_t value, char* out) {
  // Magnitude as unsigned, so -2147483648 works too.
  uint32_t magnitude = value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value);
  char digits[10];
  uint8_t count = 0;
  do {
    digits[count++] = static_cast<char>('0' + static_cast<uint8_t>(magnitude % 10u));
    magnitude /= 10u;
  } while (magnitude != 0);
  uint8_t length = 0;
  if (value < 0) out[length++] = '-';
  while (count > 0) out[length++] = digits[--count];
  return length;
}

ArrayWriter::ArrayWriter(char* buffer, size_t capacity) : buffer_(buffer), capacity_(capacity), size_(1), ok_(true) {
  clear();
}

void ArrayWriter::clear() {
  size_ = 1;
  ok_ = true;
  buffer_[0] = '[';
  buffer_[1] = ']';
  buffer_[2] = '\0';
}

ArrayWriter& ArrayWriter::add_int(int32_t value) {
  char digits[11];
  const uint8_t length = format_decimal(value, digits);
  append_value(digits, length, false);
  return *this;
}

ArrayWriter& ArrayWriter::add_string(const char* text) {
  append_value(text, text == nullptr ? 0 : strlen(text), true);
  return *this;
}

bool ArrayWriter::append_value(const char* text, size_t length, bool quoted) {
  // Needed: separator (except first), the value, quotes, then ']' and the NUL.
  const size_t separator = size_ > 1 ? 1u : 0u;
  const size_t needed = separator + length + (quoted ? 2u : 0u) + 2u;
  if (size_ + needed > capacity_) {
    ok_ = false;
    return false;
  }
  if (separator != 0) buffer_[size_++] = ',';
  if (quoted) buffer_[size_++] = '"';
  if (length != 0) memcpy(buffer_ + size_, text, length);
  size_ += length;
  if (quoted) buffer_[size_++] = '"';
  buffer_[size_] = ']';
  buffer_[size_ + 1] = '\0';
  return true;
}

}  // namespace device
}  // namespace romi
}  // namespace tether
