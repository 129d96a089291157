#include "tether/elcano/message.hpp"

#include "tether/core/crc.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/errors.hpp"

namespace tether {
namespace elcano {
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
    char digits[11];
    uint8_t count = 0;
    uint32_t magnitude = value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value);
    do {
      digits[count++] = static_cast<char>('0' + magnitude % 10u);
      magnitude /= 10u;
    } while (magnitude != 0);
    if (value < 0) put('-');
    while (count > 0) put(static_cast<uint8_t>(digits[--count]));
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

bool has_required_fields(const Message& m) {
  const bool position = set(m.east) && set(m.north);
  switch (m.type) {
    case Type::drive: return set(m.speed) && set(m.angle);
    case Type::sensor: return set(m.speed) && set(m.angle) && position && set(m.bearing);
    case Type::goal: return set(m.number) && position && set(m.bearing);
    case Type::segment: return set(m.number) && position && set(m.bearing) && set(m.speed);
  }
  return false;
}

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
