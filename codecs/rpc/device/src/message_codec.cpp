// The message codec's shared steps: see tether/rpc/device/message_codec.hpp. The rules each step mirrors are
// nanopb 0.4's (pb_decode_varint32, pb_decode_varint, pb_dec_string, ...), so that a device answers and
// refuses what it did with nanopb's generic code.
#include "tether/rpc/device/message_codec.hpp"

namespace tether {
namespace rpc {
namespace device {
namespace wire {

namespace {

// By comparisons: avr-gcc shifts a 32-bit value by 7 one bit at a time (~35 cycles a shift).
uint8_t varint_size(uint32_t value) {
  if (value < (UINT32_C(1) << 7)) return 1;
  if (value < (UINT32_C(1) << 14)) return 2;
  if (value < (UINT32_C(1) << 21)) return 3;
  return value < (UINT32_C(1) << 28) ? 4 : 5;
}

// value >> 7. avr-gcc shifts a 32-bit value by 7 one bit at a time (~35 cycles); on the AVR it is one
// shift left through the carry and a move of three bytes down (9 cycles).
__attribute__((always_inline)) inline uint32_t shift7(uint32_t value) {
#if defined(__AVR__)
  __asm__(
      "lsl %A0\n\trol %B0\n\trol %C0\n\trol %D0\n\t"
      "mov %A0, %B0\n\tmov %B0, %C0\n\tmov %C0, %D0\n\t"
      "clr %D0\n\trol %D0"  // bit 31, in the carry (EOR leaves it)
      : "+r"(value));
  return value;
#else
  return value >> 7;
#endif
}

}  // namespace

void Writer::varint(uint32_t value) {
  if (value < 0x80) {  // keys, small numbers and short lengths: most of them
    byte(static_cast<uint8_t>(value));
    return;
  }
  const uint8_t size = varint_size(value);
  if (static_cast<size_t>(end_ - at_) < size) {
    fail();
    return;
  }
  uint8_t* out = at_;
  while (value >= 0x80) {
    *out++ = static_cast<uint8_t>(value | 0x80);
    value = shift7(value);
  }
  *out++ = static_cast<uint8_t>(value);
  at_ = out;
}

void Writer::field_u32(uint32_t key, uint32_t value) {
  varint(key);
  varint(value);
}

void Writer::value_i32(int32_t value) {
  if (value >= 0) {
    varint(static_cast<uint32_t>(value));
    return;
  }
  // Its 64-bit sign extension: the low 28 bits in four bytes, bits 28..34 (31..34 ones), then 0xFF x4, 0x01.
  if (static_cast<size_t>(end_ - at_) < 10) {
    fail();
    return;
  }
  uint32_t bits = static_cast<uint32_t>(value);
  uint8_t* out = at_;
  for (uint8_t i = 0; i < 4; ++i) {
    *out++ = static_cast<uint8_t>(bits | 0x80);
    bits = shift7(bits);
  }
  *out++ = static_cast<uint8_t>(bits | 0xF0);
  for (uint8_t i = 0; i < 4; ++i) *out++ = 0xFF;
  *out++ = 0x01;
  at_ = out;
}

void Writer::field_i32(uint32_t key, int32_t value) {
  varint(key);
  value_i32(value);
}

void Writer::varint64(uint64_t value) {
  if ((value >> 32) == 0) {
    varint(static_cast<uint32_t>(value));
    return;
  }
  while (value >= 0x80) {
    byte(static_cast<uint8_t>(value | 0x80));
    value >>= 7;
  }
  byte(static_cast<uint8_t>(value));
}

void Writer::raw(const void* data, size_t size) {
  if (size == 0) return;  // (an empty bytes value; at_ may be null once failed)
  if (static_cast<size_t>(end_ - at_) < size) {
    fail();
    return;
  }
  memcpy(at_, data, size);
  at_ += size;
}

void Writer::delimited(const void* data, size_t size) {
  varint(static_cast<uint32_t>(size));
  raw(data, size);
}

void Writer::string(const char* text, size_t room) {
  if (room == 0) {
    fail();  // nanopb: "zero-length string"
    return;
  }
  size_t size = 0;
  while (size < room - 1 && text[size] != '\0') ++size;
  if (text[size] != '\0') {
    fail();  // nanopb: "unterminated string"
    return;
  }
  delimited(text, size);
}

uint8_t* Writer::open() {
  uint8_t* const mark = at_;
  byte(0);
  return mark;
}

void Writer::close(uint8_t* mark) {
  if (at_ == nullptr) return;
  const size_t length = static_cast<size_t>(at_ - mark - 1);
  if (length < 0x80) {  // the one byte `open` kept
    *mark = static_cast<uint8_t>(length);
    return;
  }
  close_long(mark, length);
}

// Out of line: the common case above then needs no saved registers.
__attribute__((noinline)) void Writer::close_long(uint8_t* mark, size_t length) {
  const uint8_t extra = static_cast<uint8_t>(varint_size(static_cast<uint32_t>(length)) - 1);
  if (static_cast<size_t>(end_ - at_) < extra) {
    fail();
    return;
  }
  memmove(mark + 1 + extra, mark + 1, length);
  at_ = mark;
  varint(static_cast<uint32_t>(length));
  at_ += length;
}

bool Reader::varint32(uint32_t& value) {
  if (at_ == end_) return false;
  uint8_t byte = *at_++;
  if ((byte & 0x80) == 0) {
    value = byte;
    return true;
  }
  uint32_t result = byte & 0x7F;
  uint8_t bitpos = 7;
  do {
    if (at_ == end_) return false;
    byte = *at_++;
    if (bitpos >= 32) {
      // Trailing 0x80 bytes, or 0xFF (0x01 last) sign extension of a negative value.
      const uint8_t sign_extension = bitpos < 63 ? 0xFF : 0x01;
      const bool valid = (byte & 0x7F) == 0x00 || ((result >> 31) != 0 && byte == sign_extension);
      if (bitpos >= 64 || !valid) return false;
    } else if (bitpos == 28) {
      if ((byte & 0x70) != 0 && (byte & 0x78) != 0x78) return false;
      result |= static_cast<uint32_t>(byte & 0x0F) << 28;
    } else {
      result |= static_cast<uint32_t>(byte & 0x7F) << bitpos;
    }
    bitpos = static_cast<uint8_t>(bitpos + 7);
  } while (byte & 0x80);
  value = result;
  return true;
}

bool Reader::key(uint32_t& key) { return varint32(key) && (key >> 3) != 0; }

bool Reader::varint_low(uint32_t& low, bool& high) {
  uint32_t result = 0;
  bool over = false;
  uint8_t bitpos = 0;
  uint8_t byte;
  do {
    if (at_ == end_) return false;
    byte = *at_++;
    if (bitpos >= 63 && (byte & 0xFE) != 0) return false;  // nanopb: "varint overflow"
    const uint8_t bits = byte & 0x7F;
    if (bitpos < 28) {
      result |= static_cast<uint32_t>(bits) << bitpos;
    } else if (bitpos == 28) {
      result |= static_cast<uint32_t>(bits) << 28;
      if ((bits >> 4) != 0) over = true;
    } else if (bits != 0) {
      over = true;
    }
    bitpos = static_cast<uint8_t>(bitpos + 7);
  } while (byte & 0x80);
  low = result;
  high = over;
  return true;
}

bool Reader::varint64(uint64_t& value) {
  uint64_t result = 0;
  uint8_t bitpos = 0;
  uint8_t byte;
  do {
    if (at_ == end_) return false;
    byte = *at_++;
    if (bitpos >= 63 && (byte & 0xFE) != 0) return false;
    result |= static_cast<uint64_t>(byte & 0x7F) << bitpos;
    bitpos = static_cast<uint8_t>(bitpos + 7);
  } while (byte & 0x80);
  value = result;
  return true;
}

bool Reader::take(void* out, size_t size) {
  if (size == 0) return true;
  if (static_cast<size_t>(end_ - at_) < size) return false;
  memcpy(out, at_, size);
  at_ += size;
  return true;
}

bool Reader::sub(Reader& inner) {
  uint32_t size;
  if (!varint32(size) || size > static_cast<size_t>(end_ - at_)) return false;  // "parent stream too short"
  inner.at_ = at_;
  inner.end_ = at_ + size;
  at_ += size;
  return true;
}

bool Reader::skip(uint8_t wire_type) {
  uint32_t size;
  switch (wire_type) {
    case 0:  // nanopb skips a varint of any length
      for (;;) {
        if (at_ == end_) return false;
        if ((*at_++ & 0x80) == 0) return true;
      }
    case 1:
      size = 8;
      break;
    case 2:
      if (!varint32(size)) return false;
      break;
    case 5:
      size = 4;
      break;
    default:
      return false;  // groups and wire types 6, 7
  }
  if (size > static_cast<size_t>(end_ - at_)) return false;
  at_ += size;
  return true;
}

bool get_string(Reader& r, char* text, size_t room) {
  uint32_t size;
  if (!r.varint32(size) || size == 0xFFFFFFFFu || size + 1 > room) return false;  // "string overflow"
  text[size] = 0;
  return r.take(text, static_cast<size_t>(size));
}

bool get_bytes(Reader& r, pb_size_t* size, uint8_t* bytes, size_t room) {
  uint32_t length;
  if (!r.varint32(length) || length > PB_SIZE_MAX || length > room) return false;  // "bytes overflow"
  *size = static_cast<pb_size_t>(length);
  return r.take(bytes, static_cast<size_t>(length));
}

bool get_fixed_bytes(Reader& r, uint8_t* bytes, size_t size) {
  uint32_t length;
  if (!r.varint32(length) || length > PB_SIZE_MAX) return false;
  if (length == 0) {  // nanopb: empty means all zeros
    memset(bytes, 0, size);
    return true;
  }
  return length == size && r.take(bytes, size);
}

}  // namespace wire
}  // namespace device
}  // namespace rpc
}  // namespace tether
