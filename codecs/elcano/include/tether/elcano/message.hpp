/// @file message.hpp
/// Elcano ring messages: `D{s 50}{a 25}\n`-style text passed around a one-way ring of boards.
///
/// Two wire generations (docs/elcano.md):
///   - **B** (primary): header `D` drive, `S` sensor, `G` goal, `X` segment; attributes `{` letter ` `
///     value `}` in the order n s a b p r, position as `{p E,N}`; `\n` ends the message.
///   - **D** (optional, adds integrity): no spaces, position split into `{p E}{q N}`, attribute order
///     n s a o b r p q (`o` obstacle), then the decimal CRC-8/SMBUS of every byte from the header to the
///     last `}`, then `\n`. Example: `D{s50}{a25}74\n`.
/// Values are int32; `kUnset` (0x7FFFFFFF, the reference's "unset") marks a field that is absent.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/status.hpp"

namespace tether {
namespace elcano {

/// The reference's "no value".
constexpr int32_t kUnset = 0x7FFFFFFF;

/// Wire generation.
enum class Generation : uint8_t {
  b,  ///< Spaces, `{p E,N}`, no checksum (primary).
  d,  ///< No spaces, `{p E}{q N}`, decimal CRC-8 trailer.
};

/// Message types (the header character).
enum class Type : uint8_t { drive = 'D', sensor = 'S', goal = 'G', segment = 'X' };

/// One message. Fields not set stay `kUnset` and are not written.
struct Message {
  Type type = Type::drive;       ///< Header.
  int32_t number = kUnset;       ///< `n` (goal, segment).
  int32_t speed = kUnset;        ///< `s` cm/s (drive, sensor, segment).
  int32_t angle = kUnset;        ///< `a` (drive, sensor).
  int32_t obstacle = kUnset;     ///< `o` mm (generation D only).
  int32_t bearing = kUnset;      ///< `b` (sensor, goal, segment).
  int32_t probability = kUnset;  ///< `r` (goal, optional).
  int32_t east = kUnset;         ///< `p` east cm (sensor, goal, segment; written only with north).
  int32_t north = kUnset;        ///< `p` north cm (gen B: second value of `p`; gen D: `q`).

  // The named constructors fill exactly the fields their type carries (the writer's table in message.cpp)
  // and leave every other one unset, so a message built with them is equal to the same message read off
  // the wire. Static members keep Message an aggregate of the same size. Not constexpr: the Arduino IDE
  // compiles TetherElcano's copy of this header as C++11, where a constexpr function is one return
  // statement and a struct with member initialisers is no aggregate, so nothing could build the result.

  /// A drive `D{s speed}{a angle}`.
  static Message drive(int32_t speed, int32_t angle) {
    Message m{};
    m.type = Type::drive;
    m.speed = speed;
    m.angle = angle;
    return m;
  }
  /// A sensor report `S{s speed}{a angle}{b bearing}{p east,north}`.
  static Message sensor(int32_t speed, int32_t angle, int32_t bearing, int32_t east, int32_t north) {
    Message m{};
    m.type = Type::sensor;
    m.speed = speed;
    m.angle = angle;
    m.bearing = bearing;
    m.east = east;
    m.north = north;
    return m;
  }
  /// A goal `G{n number}{b bearing}{p east,north}`, with `{r probability}` unless it is `kUnset` (optional).
  static Message goal(int32_t number, int32_t bearing, int32_t east, int32_t north, int32_t probability = kUnset) {
    Message m{};
    m.type = Type::goal;
    m.number = number;
    m.bearing = bearing;
    m.east = east;
    m.north = north;
    m.probability = probability;
    return m;
  }
  /// A path segment `X{n number}{s speed}{b bearing}{p east,north}`.
  static Message segment(int32_t number, int32_t speed, int32_t bearing, int32_t east, int32_t north) {
    Message m{};
    m.type = Type::segment;
    m.number = number;
    m.speed = speed;
    m.bearing = bearing;
    m.east = east;
    m.north = north;
    return m;
  }
};

/// One bit per field of `Message`, for `Decoder::fields()`: which fields a decoded message may have set.
namespace field_bits {
constexpr uint8_t number = 0x01;       ///< `number`.
constexpr uint8_t speed = 0x02;        ///< `speed`.
constexpr uint8_t angle = 0x04;        ///< `angle`.
constexpr uint8_t obstacle = 0x08;     ///< `obstacle`.
constexpr uint8_t bearing = 0x10;      ///< `bearing`.
constexpr uint8_t probability = 0x20;  ///< `probability`.
constexpr uint8_t east = 0x40;         ///< `east`.
constexpr uint8_t north = 0x80;        ///< `north`.
constexpr uint8_t all = 0xFF;          ///< Every field.
}  // namespace field_bits

/// Field-by-field equality: same type and the same value (or both unset) in every field, `obstacle` and
/// the fields the type does not carry included.
constexpr bool operator==(const Message& a, const Message& b) {
  return a.type == b.type && a.number == b.number && a.speed == b.speed && a.angle == b.angle &&
         a.obstacle == b.obstacle && a.bearing == b.bearing && a.probability == b.probability && a.east == b.east &&
         a.north == b.north;
}
/// Not `operator==`.
constexpr bool operator!=(const Message& a, const Message& b) { return !(a == b); }

/// Name of a message type: `drive`, `sensor`, `goal`, `segment` (configs, tools, logs).
const char* to_string(Type type);
/// The type named `name` (its `to_string` name or its header letter D, S, G, X); false when none is.
bool type_from_name(ByteView name, Type& type);

/// True when `message` has every field its type requires: drive s a; sensor s a p b; goal n p b (r
/// optional); segment n p b s. `p` means both east and north.
bool has_required_fields(const Message& message);

namespace detail {
/// `value != kUnset`, for a drive's line end. On the AVR the top byte is compared first: a usual value's is
/// not 0x7F, so the test is one load and one compare, where the 32-bit comparison loaded and compared four
/// bytes. Only the drive's two fields take it (each field's test grows by 8 bytes of flash).
__attribute__((always_inline)) inline bool is_set(const int32_t& value) {
#if defined(__AVR__)
  // Little-endian: the top byte is the fourth. A volatile byte read: otherwise the compiler folds this back
  // into the 32-bit comparison, all four bytes loaded first.
  if (reinterpret_cast<const volatile uint8_t*>(&value)[3] != 0x7F) return true;
#endif
  return value != kUnset;
}
/// has_required_fields inline, for the decoder's line end (the call and a position check every
/// type paid cost a drive ~60 AVR cycles); the position is checked only for the types that carry one.
__attribute__((always_inline)) inline bool required_fields_set(const Message& m) {
  switch (m.type) {
    case Type::drive: return is_set(m.speed) && is_set(m.angle);
    case Type::sensor:
      return m.speed != kUnset && m.angle != kUnset && m.bearing != kUnset && m.east != kUnset && m.north != kUnset;
    case Type::goal: return m.number != kUnset && m.bearing != kUnset && m.east != kUnset && m.north != kUnset;
    case Type::segment:
      return m.number != kUnset && m.speed != kUnset && m.bearing != kUnset && m.east != kUnset && m.north != kUnset;
  }
  return false;
}
/// The field_bits a complete message of `type` (its required fields set) may have set when it carried
/// `attributes` attributes: a drive with two carried s and a only (the usual message on a ring); any other
/// message possibly any field (field_bits::all).
__attribute__((always_inline)) inline uint8_t fields_set(Type type, uint8_t attributes) {
  return type == Type::drive && attributes == 2 ? field_bits::speed | field_bits::angle : field_bits::all;
}
}  // namespace detail

}  // namespace elcano
}  // namespace tether

// Deprecated, for one release: code that included message.hpp for write_message (now encoder.hpp's
// encode_message) or ReadError (now errors.hpp's Error) still builds.
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/errors.hpp"
