/// @file message_codec.hpp
/// A schema's messages on the wire without nanopb's generic walk: an encoder and a decoder per message,
/// written by the preprocessor from the field list nanopb's generator puts in `NAME.pb.h`
/// (`arm_State_FIELDLIST`), on the same structs. The bytes and the outcomes are nanopb's (0.4.x, static
/// allocation): proto3 fields left out when zero, repeated numbers packed, packed and unpacked accepted,
/// unknown fields skipped, and anything over the structs' bounds (a string, bytes or repeated field longer
/// than its nanopb bound, an integer over its C type) refused, never truncated. Layouts come from the
/// compiler (`sizeof`, the struct's own members), so any nanopb option that keeps a field static works;
/// a field nanopb would reach through a callback or a pointer stops the build.
///
///     TETHER_RPC_MESSAGE_DECLARE(arm_State)    // every message the schema's methods reach, then
///     TETHER_RPC_MESSAGE_DEFINE(arm_State)     // defines tether_rpc_encode_arm_State / _decode_ (below)
///
/// On the AVR its hot paths take no 64-bit arithmetic for 32-bit fields (a negative int32 is written as
/// its ten bytes directly), no per-byte calls and no descriptor reads.
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <pb.h>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the rpc message codec copies fixed32/fixed64 fields as little-endian memory"
#endif

namespace tether {
namespace rpc {
namespace device {
namespace wire {

/// A protobuf writer on a bounded buffer; once something does not fit, nothing more is written and
/// `ok()` is false.
class Writer {
 public:
  /// Writes into `capacity` bytes at `buffer`.
  Writer(uint8_t* buffer, size_t capacity) : begin_(buffer), at_(buffer), end_(buffer + capacity) {}
  /// False once something did not fit (or an encoder refused a value).
  bool ok() const { return at_ != nullptr; }
  /// Bytes written; 0 when something did not fit.
  size_t size() const { return at_ == nullptr ? 0 : static_cast<size_t>(at_ - begin_); }
  /// Gives up: nothing more is written.
  void fail() { at_ = end_ = nullptr; }
  /// Where the next byte goes (null once failed).
  uint8_t* position() const { return at_; }
  /// `size` bytes of room at `position()`, written by the caller and then kept with `advance`; null (and
  /// failed) when there is less.
  uint8_t* room(size_t size) {
    if (static_cast<size_t>(end_ - at_) < size) fail();
    return at_;
  }
  /// Keeps `size` bytes written at `position()`.
  void advance(size_t size) { at_ += size; }
  /// Drops what was written after `mark` (a `position()` of this writer).
  void rewind(uint8_t* mark) {
    if (at_ != nullptr) at_ = mark;
  }

  /// One byte.
  void byte(uint8_t value) {
    if (at_ == end_) {
      fail();
      return;
    }
    *at_++ = value;
  }
  /// A varint (a field's key, a uint32's value, a length).
  void varint(uint32_t value);
  /// A key and a uint32 (or zero-extended smaller unsigned) value.
  void field_u32(uint32_t key, uint32_t value);
  /// A key and an int32 value: a negative one as the ten bytes of its 64-bit sign extension.
  void field_i32(uint32_t key, int32_t value);
  /// An int32 value without key (packed arrays).
  void value_i32(int32_t value);
  /// A 64-bit varint value.
  void varint64(uint64_t value);
  /// `size` bytes as they are (fixed32 / fixed64 values, little-endian in memory).
  void raw(const void* data, size_t size);
  /// A length and `size` bytes (bytes values).
  void delimited(const void* data, size_t size);
  /// A string value held in `room` bytes: nanopb's rule, at most room - 1 characters and a NUL, else refused.
  void string(const char* text, size_t room);
  /// Opens a length-delimited value (a submessage, a packed array) after its key; `close` writes its length.
  uint8_t* open();
  /// Writes the length of what was written since `open` returned `mark`.
  void close(uint8_t* mark);

 private:
  void close_long(uint8_t* mark, size_t length);  // a length of two bytes or more: the value moved

  uint8_t* begin_;
  uint8_t* at_;
  uint8_t* end_;
};

/// A protobuf reader on bounded input. Each read checks what is left; false means the input is refused.
class Reader {
 public:
  /// Reads `size` bytes at `data`.
  Reader(const uint8_t* data, size_t size) : at_(data), end_(data + size) {}
  /// True while input is left.
  bool more() const { return at_ != end_; }
  /// True when all of it was read.
  bool done() const { return at_ == end_; }
  /// A field's key (nanopb's 32-bit varint rules); false for field number 0.
  bool key(uint32_t& key);
  /// A 32-bit varint by nanopb's rules (pb_decode_varint32: lengths, bools).
  bool varint32(uint32_t& value);
  /// A varint by nanopb's 64-bit rules (at most 10 bytes): its low 32 bits, and whether bits 32..63 are set.
  bool varint_low(uint32_t& low, bool& high);
  /// A varint by nanopb's 64-bit rules.
  bool varint64(uint64_t& value);
  /// `size` bytes copied to `out`.
  bool take(void* out, size_t size);
  /// A length-delimited value: `inner` reads it, this reader continues after it.
  bool sub(Reader& inner);
  /// Skips an unknown field's value of wire type `wire_type`.
  bool skip(uint8_t wire_type);

 private:
  const uint8_t* at_;
  const uint8_t* end_;
};

// Field kinds, from nanopb's FIELDLIST type names (TETHER_RPC_KIND_<type>).
struct Bool { static constexpr uint8_t kWire = 0; static constexpr bool kPackable = true; };
struct Varint { static constexpr uint8_t kWire = 0; static constexpr bool kPackable = true; };
struct Uvarint { static constexpr uint8_t kWire = 0; static constexpr bool kPackable = true; };
struct Svarint { static constexpr uint8_t kWire = 0; static constexpr bool kPackable = true; };
struct Fixed32 { static constexpr uint8_t kWire = 5; static constexpr bool kPackable = true; };
struct Fixed64 { static constexpr uint8_t kWire = 1; static constexpr bool kPackable = true; };
struct String { static constexpr uint8_t kWire = 2; static constexpr bool kPackable = false; };
struct Bytes { static constexpr uint8_t kWire = 2; static constexpr bool kPackable = false; };
struct FixedBytes { static constexpr uint8_t kWire = 2; static constexpr bool kPackable = false; };
struct Message { static constexpr uint8_t kWire = 2; static constexpr bool kPackable = false; };

// The unsigned integer of a size.
template <size_t N> struct Uint;
template <> struct Uint<1> { using type = uint8_t; };
template <> struct Uint<2> { using type = uint16_t; };
template <> struct Uint<4> { using type = uint32_t; };
template <> struct Uint<8> { using type = uint64_t; };
template <size_t N> struct Int;
template <> struct Int<1> { using type = int8_t; };
template <> struct Int<2> { using type = int16_t; };
template <> struct Int<4> { using type = int32_t; };
template <> struct Int<8> { using type = int64_t; };

// A field's memory as an integer of its size (nanopb reads fields by their size, enums included).
template <class T> inline typename Uint<sizeof(T)>::type as_unsigned(const T& value) {
  typename Uint<sizeof(T)>::type out;
  memcpy(&out, &value, sizeof out);
  return out;
}
template <class T> inline typename Int<sizeof(T)>::type as_signed(const T& value) {
  typename Int<sizeof(T)>::type out;
  memcpy(&out, &value, sizeof out);
  return out;
}
template <class T, class V> inline void store(T& field, V value) {
  static_assert(sizeof(V) == sizeof(T), "stored by size");
  memcpy(&field, &value, sizeof value);
}

// proto3's "left out when zero" (nanopb: every byte of a number zero, an empty string or bytes).
template <class T> inline bool is_zero(Bool, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(Varint, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(Uvarint, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(Svarint, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(Fixed32, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(Fixed64, const T& v) { return as_unsigned(v) == 0; }
template <class T> inline bool is_zero(String, const T& v) { return v[0] == 0; }
template <class T> inline bool is_zero(Bytes, const T& v) { return v.size == 0; }
template <class T> inline bool is_zero(FixedBytes, const T&) { return sizeof(T) == 0; }

// Values (after their key).
template <class T> inline void put(Writer& w, Bool, const T& v) { w.byte(as_unsigned(v) != 0 ? 1 : 0); }
template <class T> inline void put(Writer& w, Varint, const T& v) {
  if (sizeof(T) == 8) {
    w.varint64(static_cast<uint64_t>(as_signed(v)));
  } else {
    w.value_i32(static_cast<int32_t>(as_signed(v)));
  }
}
template <class T> inline void put(Writer& w, Uvarint, const T& v) {
  if (sizeof(T) == 8) {
    w.varint64(static_cast<uint64_t>(as_unsigned(v)));
  } else {
    w.varint(static_cast<uint32_t>(as_unsigned(v)));
  }
}
template <class T> inline void put(Writer& w, Svarint, const T& v) {
  if (sizeof(T) == 8) {
    const int64_t s = static_cast<int64_t>(as_signed(v));
    w.varint64(s < 0 ? ~(static_cast<uint64_t>(s) << 1) : static_cast<uint64_t>(s) << 1);
  } else {
    const int32_t s = static_cast<int32_t>(as_signed(v));
    w.varint(s < 0 ? ~(static_cast<uint32_t>(s) << 1) : static_cast<uint32_t>(s) << 1);
  }
}
template <class T> inline void put(Writer& w, Fixed32, const T& v) {
  static_assert(sizeof(T) == 4, "a fixed32, sfixed32 or float field is 4 bytes");
  w.raw(&v, 4);
}
template <class T> inline void put(Writer& w, Fixed64, const T& v) {
  static_assert(sizeof(T) == 8, "a fixed64, sfixed64 or double field is 8 bytes (no double on the AVR)");
  w.raw(&v, 8);
}
template <class T> inline void put(Writer& w, String, const T& v) { w.string(v, sizeof(T)); }
template <class T> inline void put(Writer& w, Bytes, const T& v) {
  if (v.size > sizeof(T) - offsetof(pb_bytes_array_t, bytes)) {
    w.fail();  // nanopb: "bytes size exceeded"
    return;
  }
  w.delimited(v.bytes, v.size);
}
template <class T> inline void put(Writer& w, FixedBytes, const T& v) { w.delimited(v, sizeof(T)); }

// Numbers (nanopb's pb_dec_varint / pb_dec_bool / fixed): false when refused.
template <class T> inline bool get(Reader& r, Bool, T& v) {
  uint32_t value;
  if (!r.varint32(value)) return false;
  store(v, static_cast<uint8_t>(value != 0 ? 1 : 0));
  return true;
}
template <class T> inline bool get(Reader& r, Varint, T& v) {
  using S = typename Int<sizeof(T)>::type;
  if (sizeof(T) == 8) {
    uint64_t value;
    if (!r.varint64(value)) return false;
    store(v, static_cast<S>(value));
    return true;
  }
  uint32_t low;
  bool high;
  if (!r.varint_low(low, high)) return false;
  const int32_t s = static_cast<int32_t>(low);  // nanopb: <= 32-bit fields take the low 32 bits as int32
  if (sizeof(T) < 4 && static_cast<int32_t>(static_cast<S>(s)) != s) return false;
  store(v, static_cast<S>(s));
  return true;
}
template <class T> inline bool get(Reader& r, Uvarint, T& v) {
  using U = typename Uint<sizeof(T)>::type;
  if (sizeof(T) == 8) {
    uint64_t value;
    if (!r.varint64(value)) return false;
    store(v, static_cast<U>(value));
    return true;
  }
  uint32_t low;
  bool high;
  if (!r.varint_low(low, high) || high) return false;
  if (sizeof(T) < 4 && static_cast<uint32_t>(static_cast<U>(low)) != low) return false;
  store(v, static_cast<U>(low));
  return true;
}
template <class T> inline bool get(Reader& r, Svarint, T& v) {
  using S = typename Int<sizeof(T)>::type;
  if (sizeof(T) == 8) {
    uint64_t value;
    if (!r.varint64(value)) return false;
    store(v, static_cast<S>((value & 1) != 0 ? ~(value >> 1) : value >> 1));
    return true;
  }
  uint32_t low;
  bool high;
  if (!r.varint_low(low, high) || high) return false;  // over 32 bits: its value is past int32
  const int32_t s = static_cast<int32_t>((low & 1) != 0 ? ~(low >> 1) : low >> 1);
  if (sizeof(T) < 4 && static_cast<int32_t>(static_cast<S>(s)) != s) return false;
  store(v, static_cast<S>(s));
  return true;
}
template <class T> inline bool get(Reader& r, Fixed32, T& v) { return r.take(&v, 4); }
template <class T> inline bool get(Reader& r, Fixed64, T& v) { return r.take(&v, 8); }
/// A string into `room` bytes (nanopb's pb_dec_string).
bool get_string(Reader& r, char* text, size_t room);
/// Bytes into a nanopb bytes struct of `room` bytes (pb_dec_bytes).
bool get_bytes(Reader& r, pb_size_t* size, uint8_t* bytes, size_t room);
/// Fixed-length bytes (pb_dec_fixed_length_bytes).
bool get_fixed_bytes(Reader& r, uint8_t* bytes, size_t size);
template <class T> inline bool get(Reader& r, String, T& v) { return get_string(r, v, sizeof(T)); }
template <class T> inline bool get(Reader& r, Bytes, T& v) {
  return get_bytes(r, &v.size, v.bytes, sizeof(T) - offsetof(pb_bytes_array_t, bytes));
}
template <class T> inline bool get(Reader& r, FixedBytes, T& v) { return get_fixed_bytes(r, v, sizeof(T)); }

// One value of a field whose key had wire type `wire` (nanopb: any other wire type is refused).
template <class K, class T> inline bool get_value(Reader& r, uint8_t wire, K kind, T& v) {
  return wire == K::kWire && get(r, kind, v);
}
// A repeated number's elements, one or packed (both accepted, as nanopb).
template <class K, class T, class C>
inline bool get_repeated(Reader& r, uint8_t wire, K kind, T* items, C& count, size_t room) {
  if (K::kPackable && wire == 2) {
    Reader packed(nullptr, 0);
    if (!r.sub(packed)) return false;
    while (packed.more() && count < room) {
      if (!get(packed, kind, items[count])) return false;
      ++count;
    }
    return packed.done();  // nanopb: "array overflow"
  }
  if (count >= room) return false;
  return get_value(r, wire, kind, items[count++]);
}

}  // namespace wire
}  // namespace device
}  // namespace rpc
}  // namespace tether

// ---- The per-message code, from nanopb's FIELDLIST X-macro: X(a, ATYPE, HTYPE, LTYPE, name, tag). ----

#define TETHER_RPC_KIND_BOOL ::tether::rpc::device::wire::Bool
#define TETHER_RPC_KIND_INT32 ::tether::rpc::device::wire::Varint
#define TETHER_RPC_KIND_INT64 ::tether::rpc::device::wire::Varint
#define TETHER_RPC_KIND_ENUM ::tether::rpc::device::wire::Varint
#define TETHER_RPC_KIND_UINT32 ::tether::rpc::device::wire::Uvarint
#define TETHER_RPC_KIND_UINT64 ::tether::rpc::device::wire::Uvarint
#define TETHER_RPC_KIND_UENUM ::tether::rpc::device::wire::Uvarint
#define TETHER_RPC_KIND_SINT32 ::tether::rpc::device::wire::Svarint
#define TETHER_RPC_KIND_SINT64 ::tether::rpc::device::wire::Svarint
#define TETHER_RPC_KIND_FIXED32 ::tether::rpc::device::wire::Fixed32
#define TETHER_RPC_KIND_SFIXED32 ::tether::rpc::device::wire::Fixed32
#define TETHER_RPC_KIND_FLOAT ::tether::rpc::device::wire::Fixed32
#define TETHER_RPC_KIND_FIXED64 ::tether::rpc::device::wire::Fixed64
#define TETHER_RPC_KIND_SFIXED64 ::tether::rpc::device::wire::Fixed64
#define TETHER_RPC_KIND_DOUBLE ::tether::rpc::device::wire::Fixed64
#define TETHER_RPC_KIND_STRING ::tether::rpc::device::wire::String
#define TETHER_RPC_KIND_BYTES ::tether::rpc::device::wire::Bytes
#define TETHER_RPC_KIND_FIXED_LENGTH_BYTES ::tether::rpc::device::wire::FixedBytes
#define TETHER_RPC_KIND_MESSAGE ::tether::rpc::device::wire::Message

// A field's key: (number << 3) | wire type.
#define TETHER_RPC_KEY(ltype, tag) ((static_cast<uint32_t>(tag) << 3) | TETHER_RPC_KIND_##ltype::kWire)

// A oneof member's name is (oneof, member, oneof.member).
#define TETHER_RPC_ONEOF_WHICH(oneof, member, path) which_##oneof
#define TETHER_RPC_ONEOF_PATH(oneof, member, path) path
#define TETHER_RPC_APPLY(macro, args) macro args

// Encoding one field: a value after its key. Messages and the rest differ (a submessage's length).
#define TETHER_RPC_PUT_MESSAGE(ltype, field, tag) \
  do {                                            \
    w.varint(TETHER_RPC_KEY(ltype, tag));         \
    uint8_t* const mark_ = w.open();              \
    tether_rpc_encode(w, field);                  \
    w.close(mark_);                               \
  } while (0)
#define TETHER_RPC_PUT_PLAIN(ltype, field, tag)                        \
  do {                                                                 \
    w.varint(TETHER_RPC_KEY(ltype, tag));                              \
    ::tether::rpc::device::wire::put(w, TETHER_RPC_KIND_##ltype(), field); \
  } while (0)
#define TETHER_RPC_PUT_ONE_MESSAGE(ltype, field, tag) TETHER_RPC_PUT_MESSAGE(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_BOOL(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_INT32(ltype, field, tag) w.field_i32(TETHER_RPC_KEY(ltype, tag), static_cast<int32_t>(::tether::rpc::device::wire::as_signed(field)))
#define TETHER_RPC_PUT_ONE_ENUM(ltype, field, tag) TETHER_RPC_PUT_ONE_INT32(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_UINT32(ltype, field, tag) w.field_u32(TETHER_RPC_KEY(ltype, tag), static_cast<uint32_t>(::tether::rpc::device::wire::as_unsigned(field)))
#define TETHER_RPC_PUT_ONE_UENUM(ltype, field, tag) TETHER_RPC_PUT_ONE_UINT32(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_INT64(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_UINT64(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_SINT32(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_SINT64(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_FIXED32(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_SFIXED32(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_FLOAT(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_FIXED64(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_SFIXED64(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_DOUBLE(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_STRING(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_BYTES(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE_FIXED_LENGTH_BYTES(ltype, field, tag) TETHER_RPC_PUT_PLAIN(ltype, field, tag)
#define TETHER_RPC_PUT_ONE(ltype, field, tag) TETHER_RPC_PUT_ONE_##ltype(ltype, field, tag)

// Repeated: numbers packed (nanopb always packs them), the rest one key per element.
#define TETHER_RPC_PUT_REPEATED_NUMBER(ltype, name, tag)                                     \
  do {                                                                                      \
    const pb_size_t count_ = m.name##_count;                                                \
    if (count_ > sizeof m.name / sizeof m.name[0]) {                                        \
      w.fail(); /* nanopb: "array max size exceeded" */                                     \
    } else if (count_ != 0) {                                                               \
      w.varint((static_cast<uint32_t>(tag) << 3) | 2);                                      \
      uint8_t* const mark_ = w.open();                                                      \
      for (pb_size_t i_ = 0; i_ < count_; ++i_) {                                           \
        ::tether::rpc::device::wire::put(w, TETHER_RPC_KIND_##ltype(), m.name[i_]);         \
      }                                                                                     \
      w.close(mark_);                                                                       \
    }                                                                                       \
  } while (0)
#define TETHER_RPC_PUT_REPEATED_ELEMENTS(ltype, name, tag, put_one)                         \
  do {                                                                                      \
    const pb_size_t count_ = m.name##_count;                                                \
    if (count_ > sizeof m.name / sizeof m.name[0]) {                                        \
      w.fail();                                                                             \
    } else {                                                                                \
      for (pb_size_t i_ = 0; i_ < count_; ++i_) put_one(ltype, m.name[i_], tag);            \
    }                                                                                       \
  } while (0)
#define TETHER_RPC_PUT_REPEATED_MESSAGE(ltype, name, tag) TETHER_RPC_PUT_REPEATED_ELEMENTS(ltype, name, tag, TETHER_RPC_PUT_MESSAGE)
#define TETHER_RPC_PUT_REPEATED_STRING(ltype, name, tag) TETHER_RPC_PUT_REPEATED_ELEMENTS(ltype, name, tag, TETHER_RPC_PUT_PLAIN)
#define TETHER_RPC_PUT_REPEATED_BYTES(ltype, name, tag) TETHER_RPC_PUT_REPEATED_ELEMENTS(ltype, name, tag, TETHER_RPC_PUT_PLAIN)
#define TETHER_RPC_PUT_REPEATED_FIXED_LENGTH_BYTES(ltype, name, tag) TETHER_RPC_PUT_REPEATED_ELEMENTS(ltype, name, tag, TETHER_RPC_PUT_PLAIN)
#define TETHER_RPC_PUT_REPEATED_BOOL TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_INT32 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_INT64 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_ENUM TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_UINT32 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_UINT64 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_UENUM TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_SINT32 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_SINT64 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_FIXED32 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_SFIXED32 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_FLOAT TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_FIXED64 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_SFIXED64 TETHER_RPC_PUT_REPEATED_NUMBER
#define TETHER_RPC_PUT_REPEATED_DOUBLE TETHER_RPC_PUT_REPEATED_NUMBER

// Singular (proto3: left out when zero), optional (has_), repeated, oneof (which_).
#define TETHER_RPC_ENC_STATIC_SINGULAR(ltype, name, tag) \
  if (!TETHER_RPC_IS_ZERO_##ltype(ltype, m.name)) TETHER_RPC_PUT_ONE(ltype, m.name, tag);
#define TETHER_RPC_IS_ZERO_MESSAGE(ltype, field) tether_rpc_is_default(field)
#define TETHER_RPC_IS_ZERO_PLAIN(ltype, field) ::tether::rpc::device::wire::is_zero(TETHER_RPC_KIND_##ltype(), field)
#define TETHER_RPC_IS_ZERO_BOOL TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_INT32 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_INT64 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_ENUM TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_UINT32 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_UINT64 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_UENUM TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_SINT32 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_SINT64 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_FIXED32 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_SFIXED32 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_FLOAT TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_FIXED64 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_SFIXED64 TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_DOUBLE TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_STRING TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_BYTES TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_IS_ZERO_FIXED_LENGTH_BYTES TETHER_RPC_IS_ZERO_PLAIN
#define TETHER_RPC_ENC_STATIC_OPTIONAL(ltype, name, tag) \
  if (m.has_##name) TETHER_RPC_PUT_ONE(ltype, m.name, tag);
#define TETHER_RPC_ENC_STATIC_REQUIRED(ltype, name, tag) TETHER_RPC_PUT_ONE(ltype, m.name, tag);
#define TETHER_RPC_ENC_STATIC_REPEATED(ltype, name, tag) TETHER_RPC_PUT_REPEATED_##ltype(ltype, name, tag);
#define TETHER_RPC_ENC_STATIC_ONEOF(ltype, name, tag)                  \
  if (m.TETHER_RPC_APPLY(TETHER_RPC_ONEOF_WHICH, name) == (tag)) \
    TETHER_RPC_PUT_ONE(ltype, m.TETHER_RPC_APPLY(TETHER_RPC_ONEOF_PATH, name), tag);
#define TETHER_RPC_ENC_FIELD(a, atype, htype, ltype, name, tag) TETHER_RPC_ENC_##atype##_##htype(ltype, name, tag)

// proto3 default of a singular submessage without has_ (nanopb looks at each field).
#define TETHER_RPC_DEFAULT_STATIC_SINGULAR(ltype, name, tag) &&TETHER_RPC_IS_ZERO_##ltype(ltype, m.name)
#define TETHER_RPC_DEFAULT_STATIC_OPTIONAL(ltype, name, tag) && !m.has_##name
#define TETHER_RPC_DEFAULT_STATIC_REQUIRED(ltype, name, tag) && false
#define TETHER_RPC_DEFAULT_STATIC_REPEATED(ltype, name, tag) && m.name##_count == 0
#define TETHER_RPC_DEFAULT_STATIC_ONEOF(ltype, name, tag) && m.TETHER_RPC_APPLY(TETHER_RPC_ONEOF_WHICH, name) == 0
#define TETHER_RPC_DEFAULT_FIELD(a, atype, htype, ltype, name, tag) TETHER_RPC_DEFAULT_##atype##_##htype(ltype, name, tag)

// Decoding one field (a `case` of the message's switch on the field number).
#define TETHER_RPC_GET_VALUE(ltype, field) TETHER_RPC_GET_VALUE_##ltype(ltype, field)
#define TETHER_RPC_GET_MESSAGE(ltype, field) \
  (wire_ == 2 && r.sub(inner_) && tether_rpc_decode(inner_, field))
#define TETHER_RPC_GET_PLAIN(ltype, field) \
  ::tether::rpc::device::wire::get_value(r, wire_, TETHER_RPC_KIND_##ltype(), field)
#define TETHER_RPC_GET_VALUE_MESSAGE TETHER_RPC_GET_MESSAGE
#define TETHER_RPC_GET_VALUE_BOOL TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_INT32 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_INT64 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_ENUM TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_UINT32 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_UINT64 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_UENUM TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_SINT32 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_SINT64 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_FIXED32 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_SFIXED32 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_FLOAT TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_FIXED64 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_SFIXED64 TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_DOUBLE TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_STRING TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_BYTES TETHER_RPC_GET_PLAIN
#define TETHER_RPC_GET_VALUE_FIXED_LENGTH_BYTES TETHER_RPC_GET_PLAIN
// A repeated field: numbers through get_repeated (packed or not), the rest one element per key (a
// submessage element starts from zero, as nanopb's).
#define TETHER_RPC_GET_REPEATED(ltype, name) TETHER_RPC_GET_REPEATED_##ltype(ltype, name)
#define TETHER_RPC_GET_REPEATED_NUMBER(ltype, name)                                                   \
  ::tether::rpc::device::wire::get_repeated(r, wire_, TETHER_RPC_KIND_##ltype(), m.name, m.name##_count, \
                                            sizeof m.name / sizeof m.name[0])
#define TETHER_RPC_GET_REPEATED_ELEMENT(ltype, name)                                     \
  (m.name##_count < sizeof m.name / sizeof m.name[0] &&                                  \
   (memset(&m.name[m.name##_count], 0, sizeof m.name[0]), true) &&                      \
   TETHER_RPC_GET_VALUE(ltype, m.name[m.name##_count++]))
#define TETHER_RPC_GET_REPEATED_MESSAGE TETHER_RPC_GET_REPEATED_ELEMENT
#define TETHER_RPC_GET_REPEATED_STRING TETHER_RPC_GET_REPEATED_ELEMENT
#define TETHER_RPC_GET_REPEATED_BYTES TETHER_RPC_GET_REPEATED_ELEMENT
#define TETHER_RPC_GET_REPEATED_FIXED_LENGTH_BYTES TETHER_RPC_GET_REPEATED_ELEMENT
#define TETHER_RPC_GET_REPEATED_BOOL TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_INT32 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_INT64 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_ENUM TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_UINT32 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_UINT64 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_UENUM TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_SINT32 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_SINT64 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_FIXED32 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_SFIXED32 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_FLOAT TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_FIXED64 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_SFIXED64 TETHER_RPC_GET_REPEATED_NUMBER
#define TETHER_RPC_GET_REPEATED_DOUBLE TETHER_RPC_GET_REPEATED_NUMBER
// A oneof member: switching to a submessage member starts it from zero (nanopb's memset).
#define TETHER_RPC_ONEOF_RESET_MESSAGE(which, field, tag) \
  if (m.which != (tag)) memset(&m.field, 0, sizeof m.field);
#define TETHER_RPC_ONEOF_RESET_OTHER(which, field, tag)
#define TETHER_RPC_ONEOF_RESET(ltype) TETHER_RPC_ONEOF_RESET_##ltype
#define TETHER_RPC_ONEOF_RESET_BOOL TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_INT32 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_INT64 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_ENUM TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_UINT32 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_UINT64 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_UENUM TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_SINT32 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_SINT64 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_FIXED32 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_SFIXED32 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_FLOAT TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_FIXED64 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_SFIXED64 TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_DOUBLE TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_STRING TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_BYTES TETHER_RPC_ONEOF_RESET_OTHER
#define TETHER_RPC_ONEOF_RESET_FIXED_LENGTH_BYTES TETHER_RPC_ONEOF_RESET_OTHER

#define TETHER_RPC_DEC_STATIC_SINGULAR(ltype, name, tag) \
  case tag:                                              \
    if (!TETHER_RPC_GET_VALUE(ltype, m.name)) return false; \
    break;
#define TETHER_RPC_DEC_STATIC_REQUIRED(ltype, name, tag) \
  static_assert(false && (tag), "proto2 required fields are not supported");
#define TETHER_RPC_DEC_STATIC_OPTIONAL(ltype, name, tag)    \
  case tag:                                                 \
    m.has_##name = true;                                    \
    if (!TETHER_RPC_GET_VALUE(ltype, m.name)) return false; \
    break;
#define TETHER_RPC_DEC_STATIC_REPEATED(ltype, name, tag)       \
  case tag:                                                    \
    if (!TETHER_RPC_GET_REPEATED(ltype, name)) return false;   \
    break;
#define TETHER_RPC_DEC_STATIC_ONEOF(ltype, name, tag)                                                          \
  case tag:                                                                                                    \
    TETHER_RPC_ONEOF_RESET(ltype)(TETHER_RPC_APPLY(TETHER_RPC_ONEOF_WHICH, name),                              \
                                  TETHER_RPC_APPLY(TETHER_RPC_ONEOF_PATH, name), tag)                          \
    m.TETHER_RPC_APPLY(TETHER_RPC_ONEOF_WHICH, name) = (tag);                                                  \
    if (!TETHER_RPC_GET_VALUE(ltype, m.TETHER_RPC_APPLY(TETHER_RPC_ONEOF_PATH, name))) return false;           \
    break;
#define TETHER_RPC_DEC_FIELD(a, atype, htype, ltype, name, tag) TETHER_RPC_DEC_##atype##_##htype(ltype, name, tag)

/// Declares message `M`'s encoder, decoder and proto3-default check (before any message that holds one).
#define TETHER_RPC_MESSAGE_DECLARE(M)                                                  \
  void tether_rpc_encode(::tether::rpc::device::wire::Writer& w, const M& m);          \
  bool tether_rpc_decode(::tether::rpc::device::wire::Reader& r, M& m);                \
  inline bool tether_rpc_is_default(const M& m);                                       \
  bool tether_rpc_encode_##M(::tether::rpc::device::wire::Writer& w, const void* m);   \
  bool tether_rpc_decode_##M(const uint8_t* data, size_t size, void* m);

/// Defines message `M`'s code: `tether_rpc_encode_M(writer, &m)` (false when it did not fit or a field
/// is over its bound) and `tether_rpc_decode_M(data, size, &m)` (`m` from zero; false when refused).
#define TETHER_RPC_MESSAGE_DEFINE(M)                                                     \
  void tether_rpc_encode(::tether::rpc::device::wire::Writer& w, const M& m) {           \
    (void)w;                                                                             \
    (void)m;                                                                             \
    M##_FIELDLIST(TETHER_RPC_ENC_FIELD, M)                                               \
  }                                                                                      \
  bool tether_rpc_decode(::tether::rpc::device::wire::Reader& r, M& m) {                 \
    (void)m;                                                                             \
    while (r.more()) {                                                                   \
      uint32_t key_;                                                                     \
      if (!r.key(key_)) return false;                                                    \
      const uint8_t wire_ = static_cast<uint8_t>(key_ & 7);                              \
      ::tether::rpc::device::wire::Reader inner_(nullptr, 0);                            \
      (void)inner_;                                                                      \
      switch (key_ >> 3) {                                                               \
        M##_FIELDLIST(TETHER_RPC_DEC_FIELD, M)                                           \
        default:                                                                         \
          if (!r.skip(wire_)) return false;                                              \
      }                                                                                  \
    }                                                                                    \
    return true;                                                                         \
  }                                                                                      \
  inline bool tether_rpc_is_default(const M& m) {                                        \
    (void)m;                                                                             \
    return true M##_FIELDLIST(TETHER_RPC_DEFAULT_FIELD, M);                              \
  }                                                                                      \
  bool tether_rpc_encode_##M(::tether::rpc::device::wire::Writer& w, const void* m) {    \
    tether_rpc_encode(w, *static_cast<const M*>(m));                                     \
    return w.ok();                                                                       \
  }                                                                                      \
  bool tether_rpc_decode_##M(const uint8_t* data, size_t size, void* m) {                \
    memset(m, 0, sizeof(M));                                                             \
    ::tether::rpc::device::wire::Reader r(data, size);                                   \
    return tether_rpc_decode(r, *static_cast<M*>(m));                                    \
  }
