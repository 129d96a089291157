/// @file array_text.hpp
/// Builds the JSON array text a handler passes to `IRomiSerial::send()`, without printf (avr-libc's
/// snprintf costs ~1.5 KB of flash) and without the heap.
///
///     ArrayText<16> reply;            // 16 bytes, NUL included
///     reply.add_int(0).add_int(sensor_value);  // "[0,512]"
///     romi->send(reply.c_str());
///
/// Strings are written between double quotes without escaping (the Romi protocol has no escapes): they
/// must not contain `"`. When the text does not fit, `ok()` turns false and the text stays a valid array
/// of the values that fitted.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {
namespace romi {
namespace device {

/// Writes decimal `value` at `out` (no NUL); returns the number of characters (1..11).
/// `out` needs room for 11 characters ("-2147483648").
uint8_t format_decimal(int32_t value, char* out);

/// Array builder over a caller's buffer; see `ArrayText` for one with its own storage.
class ArrayWriter {
 public:
  /// Writer into `buffer` of `capacity` bytes (at least 3: "[]" and the NUL); starts as "[]".
  ArrayWriter(char* buffer, size_t capacity);
  /// Appends an integer value. (Two names, not overloads: `add(0)` would be ambiguous on the AVR,
  /// where 0 converts to `int32_t` and to a null pointer with the same rank.)
  ArrayWriter& add_int(int32_t value);
  /// Appends a string value in double quotes (null is ""). Not escaped: must not contain `"`.
  ArrayWriter& add_string(const char* text);
  /// The array text, NUL-terminated (e.g. "[0,1,2]"); valid until the next `add`.
  const char* c_str() const { return buffer_; }
  /// Characters of the text, brackets included.
  size_t size() const { return size_ + 1; }
  /// False when a value did not fit (it was left out entirely).
  bool ok() const { return ok_; }
  /// Back to "[]".
  void clear();

 private:
  bool append_value(const char* text, size_t length, bool quoted);

  char* buffer_;
  size_t capacity_;
  size_t size_;  // characters before the closing ']'
  bool ok_;
};

/// `ArrayWriter` with a `Capacity`-byte buffer inside (NUL included).
template <size_t Capacity>
class ArrayText : public ArrayWriter {
  static_assert(Capacity >= 3, "room for \"[]\" and the NUL");

 public:
  /// Empty array "[]".
  ArrayText() : ArrayWriter(storage_, Capacity) {}
  /// Not copyable (the base points into this object's storage).
  ArrayText(const ArrayText&) = delete;
  /// Not assignable.
  ArrayText& operator=(const ArrayText&) = delete;
  /// Appends an integer value.
  ArrayText& add_int(int32_t value) {
    ArrayWriter::add_int(value);
    return *this;
  }
  /// Appends a string value (see `ArrayWriter::add_string`).
  ArrayText& add_string(const char* text) {
    ArrayWriter::add_string(text);
    return *this;
  }

 private:
  char storage_[Capacity];
};

}  // namespace device
}  // namespace romi
}  // namespace tether
