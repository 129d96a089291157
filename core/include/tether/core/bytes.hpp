/// @file bytes.hpp
/// Non-owning byte views shared by every codec, for the host and the AVR alike.
///
/// `ByteView` is a read-only (pointer, length) pair, `MutableByteView` a writable one. They never own
/// memory: the caller keeps the bytes alive while a view is in use. Neither allocates or throws, so both
/// build with avr-gcc 5.4 (gnu++14, no standard library).
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {

/// Read-only view of contiguous bytes.
class ByteView {
 public:
  /// Empty view.
  constexpr ByteView() : data_(nullptr), size_(0) {}
  /// View of `size` bytes at `data` (`data` may be null only when `size` is 0).
  constexpr ByteView(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  /// View of the characters of a string literal without its terminating NUL.
  template <size_t N>
  static constexpr ByteView from_literal(const char (&text)[N]) {
    return ByteView(reinterpret_cast<const uint8_t*>(text), N - 1);
  }
  /// View of `size` characters at `text`.
  static ByteView from_chars(const char* text, size_t size) {
    return ByteView(reinterpret_cast<const uint8_t*>(text), size);
  }

  /// First byte, or null for an empty view.
  constexpr const uint8_t* data() const { return data_; }
  /// Number of bytes.
  constexpr size_t size() const { return size_; }
  /// True when the view has no bytes.
  constexpr bool empty() const { return size_ == 0; }
  /// Byte at `index`; `index < size()` is the caller's duty.
  constexpr uint8_t operator[](size_t index) const { return data_[index]; }
  /// Iteration support.
  constexpr const uint8_t* begin() const { return data_; }
  /// Iteration support.
  constexpr const uint8_t* end() const { return data_ + size_; }
  /// The bytes from `offset` on, at most `count` of them; clamped to the view, never out of bounds.
  constexpr ByteView subview(size_t offset, size_t count = static_cast<size_t>(-1)) const {
    return offset >= size_ ? ByteView(data_ + size_, 0)
                           : ByteView(data_ + offset, count < size_ - offset ? count : size_ - offset);
  }
  /// Byte-wise equality.
  bool equals(ByteView other) const {
    if (other.size_ != size_) return false;
    for (size_t i = 0; i < size_; ++i) {
      if (data_[i] != other.data_[i]) return false;
    }
    return true;
  }

 private:
  const uint8_t* data_;
  size_t size_;
};

/// Writable view of contiguous bytes (an output buffer handed to an encoder).
class MutableByteView {
 public:
  /// Empty view.
  constexpr MutableByteView() : data_(nullptr), size_(0) {}
  /// View of `size` writable bytes at `data`.
  constexpr MutableByteView(uint8_t* data, size_t size) : data_(data), size_(size) {}
  /// View of a whole array.
  template <size_t N>
  constexpr MutableByteView(uint8_t (&array)[N]) : data_(array), size_(N) {}  // NOLINT: implicit on purpose

  /// First byte.
  constexpr uint8_t* data() const { return data_; }
  /// Number of bytes.
  constexpr size_t size() const { return size_; }
  /// Byte at `index`; `index < size()` is the caller's duty.
  constexpr uint8_t& operator[](size_t index) const { return data_[index]; }
  /// Read-only view of the first `count` bytes (clamped).
  constexpr ByteView first(size_t count) const { return ByteView(data_, count < size_ ? count : size_); }
  /// Read-only view of the whole buffer.
  constexpr operator ByteView() const { return ByteView(data_, size_); }  // NOLINT: implicit on purpose

 private:
  uint8_t* data_;
  size_t size_;
};

}  // namespace tether
