// JSON array text for handler replies (array_text.hpp).
#include "tether/romi/device/array_text.hpp"

#include <string.h>

namespace tether {
namespace romi {
namespace device {

namespace {

// Writes the digit of `magnitude` at `power` (a power of ten) by subtraction, skipping leading zeros:
// no division (a library call of ~600 cycles per digit on the AVR) and no table of powers in RAM.
// Out of line: eleven inlined copies cost ~300 B of flash.
template <typename Unsigned>
__attribute__((noinline)) void put_digit(Unsigned& magnitude, Unsigned power, char*& out, bool& started) {
  uint8_t digit = 0;
  while (magnitude >= power) {
    magnitude = static_cast<Unsigned>(magnitude - power);
    ++digit;
  }
  if (digit != 0 || started) {
    *out++ = static_cast<char>('0' + digit);
    started = true;
  }
}

}  // namespace

uint8_t format_decimal(int32_t value, char* out) {
  // Magnitude as unsigned, so -2147483648 works too.
  uint32_t magnitude = value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value);
  char* next = out;
  if (value < 0) *next++ = '-';
  bool started = false;
  uint16_t low;
  if (magnitude > 0xFFFFu) {
    put_digit<uint32_t>(magnitude, 1000000000u, next, started);
    put_digit<uint32_t>(magnitude, 100000000u, next, started);
    put_digit<uint32_t>(magnitude, 10000000u, next, started);
    put_digit<uint32_t>(magnitude, 1000000u, next, started);
    put_digit<uint32_t>(magnitude, 100000u, next, started);
    put_digit<uint32_t>(magnitude, 10000u, next, started);
    low = static_cast<uint16_t>(magnitude);  // below 10000
  } else {
    // 16-bit arithmetic from here (a reply's values are int16 almost always).
    low = static_cast<uint16_t>(magnitude);
    put_digit<uint16_t>(low, 10000u, next, started);
  }
  put_digit<uint16_t>(low, 1000u, next, started);
  put_digit<uint16_t>(low, 100u, next, started);
  put_digit<uint16_t>(low, 10u, next, started);
  *next++ = static_cast<char>('0' + low);
  return static_cast<uint8_t>(next - out);
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
