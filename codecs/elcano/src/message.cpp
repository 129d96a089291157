#include "tether/elcano/message.hpp"

#include <stddef.h>

#include "tether/core/crc.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/errors.hpp"

namespace tether {
namespace elcano {
namespace detail {

#if defined(__AVR__)
const uint8_t kFieldOffsets[26] PROGMEM = {
#else
const uint8_t kFieldOffsets[26] = {
#endif
    offsetof(Message, angle),  // a
    offsetof(Message, bearing),  // b
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,  // c..m
    offsetof(Message, number),  // n
    offsetof(Message, obstacle) | kGenerationDOnly,  // o
    offsetof(Message, east) | kGenerationDOnly,  // p (generation B: E,N, two fields)
    offsetof(Message, north) | kGenerationDOnly,  // q
    offsetof(Message, probability),  // r
    offsetof(Message, speed),  // s
    0, 0, 0, 0, 0, 0, 0,  // t..z
};

}  // namespace detail

namespace {

bool set(int32_t value) { return value != kUnset; }

class TextWriter {
 public:
  explicit TextWriter(MutableByteView out) : out_(out) {}
  void put(uint8_t c) {
    if (size_ < out_.size()) out_[size_] = c;
    ++size_;
  }
  void put_number(int32_t value) {
    if (value < 0) put('-');
    put_magnitude(value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value));
  }
  // Decimal digits without division (on the AVR a 32-bit division is a ~600-cycle library call per
  // digit) and without a table of powers of ten (a const table would sit in the AVR's RAM): the powers
  // up to `value` are built by multiplying (shifts and adds), then each digit counts the subtractions
  // of its power. Below 65536, where the protocol's values usually are, in 16-bit arithmetic.
  // On the host a division by 10 is a multiply, faster than counting subtractions: the host keeps it.
  void put_magnitude(uint32_t value) {
#if defined(__AVR__)
    if (value <= 0xFFFFu) {
      put_decimal<uint16_t>(static_cast<uint16_t>(value), 10000u);
    } else {
      put_decimal<uint32_t>(value, 1000000000u);
    }
#else
    char digits[10];
    uint8_t count = 0;
    do {
      digits[count++] = static_cast<char>('0' + value % 10u);
      value /= 10u;
    } while (value != 0);
    while (count > 0) put(static_cast<uint8_t>(digits[--count]));
#endif
  }
  template <typename Unsigned>
  void put_decimal(Unsigned value, Unsigned largest_power) {
    Unsigned powers[10];
    uint8_t count = 0;
    Unsigned power = 1;
    for (;;) {
      powers[count++] = power;
      if (power == largest_power) break;
      const Unsigned next = static_cast<Unsigned>((power << 3) + (power << 1));
      if (next > value) break;
      power = next;
    }
    while (count != 0) {
      const Unsigned step = powers[--count];
      uint8_t digit = 0;
      while (value >= step) {
        value = static_cast<Unsigned>(value - step);
        ++digit;
      }
      put(static_cast<uint8_t>('0' + digit));
    }
  }
  void attribute(char letter, int32_t value, bool spaced) {
    if (!set(value)) return;
    put('{');
    put(static_cast<uint8_t>(letter));
    if (spaced) put(' ');
    put_number(value);
    put('}');
  }
  size_t size() const { return size_; }
  bool fits() const { return size_ <= out_.size(); }
  ByteView written() const { return ByteView(out_.data(), size_); }

 private:
  MutableByteView out_;
  size_t size_ = 0;
};

// Which attributes a type carries (the reference writer's table).
struct Uses {
  bool n, s, a, b, p, r;
};
Uses uses(Type type) {
  switch (type) {
    case Type::drive: return {false, true, true, false, false, false};
    case Type::sensor: return {false, true, true, true, true, false};
    case Type::goal: return {true, false, false, true, true, true};
    case Type::segment: return {true, true, false, true, true, false};
  }
  return {false, false, false, false, false, false};
}

}  // namespace

const char* describe(Error error) {
  switch (error) {
    case Error::success: return "success";
    case Error::bad_type: return "bad_type";
    case Error::bad_lcurly: return "bad_lcurly";
    case Error::bad_attrib: return "bad_attrib";
    case Error::bad_number: return "bad_number";
    case Error::inval_comb: return "inval_comb";
    case Error::bad_crc: return "bad_crc";
    case Error::too_long: return "too_long";
    case Error::timed_out: return "timed_out";
    case Error::queue_full: return "queue_full";
  }
  return "unknown";
}

const char* to_string(Type type) {
  switch (type) {
    case Type::drive: return "drive";
    case Type::sensor: return "sensor";
    case Type::goal: return "goal";
    case Type::segment: return "segment";
  }
  return "unknown";
}

bool type_from_name(ByteView name, Type& type) {
  static const Type kTypes[] = {Type::drive, Type::sensor, Type::goal, Type::segment};
  for (const Type candidate : kTypes) {
    if (name.size() == 1 && name[0] == static_cast<uint8_t>(candidate)) {
      type = candidate;
      return true;
    }
    const char* text = to_string(candidate);
    size_t i = 0;
    while (i < name.size() && text[i] != '\0' && name[i] == static_cast<uint8_t>(text[i])) ++i;
    if (i == name.size() && text[i] == '\0') {
      type = candidate;
      return true;
    }
  }
  return false;
}

bool has_required_fields(const Message& m) { return detail::required_fields_set(m); }

Result<size_t> encode_message(const Message& m, Generation generation, MutableByteView out) {
  if (!has_required_fields(m)) return Status::invalid_argument;
  const Uses u = uses(m.type);
  const bool b = generation == Generation::b;
  TextWriter w(out);
  w.put(static_cast<uint8_t>(m.type));
  if (u.n) w.attribute('n', m.number, b);
  if (u.s) w.attribute('s', m.speed, b);
  if (u.a) w.attribute('a', m.angle, b);
  if (b) {
    if (u.b) w.attribute('b', m.bearing, true);
    if (u.p && set(m.east) && set(m.north)) {
      w.put('{');
      w.put('p');
      w.put(' ');
      w.put_number(m.east);
      w.put(',');
      w.put_number(m.north);
      w.put('}');
    }
    if (u.r) w.attribute('r', m.probability, true);
  } else {
    w.attribute('o', m.obstacle, false);
    if (u.b) w.attribute('b', m.bearing, false);
    if (u.r) w.attribute('r', m.probability, false);
    if (u.p && set(m.east) && set(m.north)) {
      w.attribute('p', m.east, false);
      w.attribute('q', m.north, false);
    }
    if (w.fits()) w.put_number(Crc8Smbus::compute(w.written()));
  }
  w.put('\n');
  if (!w.fits()) return Status::buffer_too_small;
  return w.size();
}

}  // namespace elcano
}  // namespace tether
