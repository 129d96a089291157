// Implementation of decoder.hpp (a template: the capacity is the user's choice).
#pragma once

namespace tether {
namespace elcano {
namespace detail {

__attribute__((always_inline)) inline bool is_header(uint8_t c) { return c == 'D' || c == 'S' || c == 'G' || c == 'X'; }
inline bool is_ignored(uint8_t c) { return c == ' ' || c == '\t' || c == '\r' || c == '\0'; }

// Decoder::run's `*out++ = byte`: on the AVR a post-increment store in assembly (the compiler's own stored,
// then stepped the pointer: 2 cycles a byte more).
__attribute__((always_inline)) inline void store_next(uint8_t*& out, uint8_t byte) {
#if defined(__AVR__)
  __asm__ volatile("st %a[out]+, %[byte]" : [out] "+e"(out) : [byte] "r"(byte) : "memory");
#else
  *out++ = byte;
#endif
}

// Decoder::run's `value * 10 + digit` for a number's fifth to ninth digit (value < 10^8: no overflow). On the
// AVR byte by byte on the hardware multiplier, in place: six registers, where avr-gcc's shifts and adds
// held two 32-bit values and a constant, four more registers that run() saved and restored on every call.
__attribute__((always_inline)) inline uint32_t times_ten_plus(uint32_t value, uint8_t digit) {
#if defined(__AVR__)
  // Each byte times 10 is at most 2550: its high byte (at most 9) plus the carry of adding the carry in
  // (the digit at first) is the next byte's carry, at most 10; the top byte's high byte is 0 (< 10^9).
  uint8_t carry = digit;
  uint8_t ten;  // loaded here: an input operand would be hoisted into a register held across run()'s loops
  __asm__(
      "ldi %[ten], 10\n\t"
      "mul %A[value], %[ten]\n\t"
      "add r0, %[carry]\n\t"
      "mov %A[value], r0\n\t"
      "mov %[carry], r1\n\t"
      "brcc 1f\n\t"
      "inc %[carry]\n"
      "1: mul %B[value], %[ten]\n\t"
      "add r0, %[carry]\n\t"
      "mov %B[value], r0\n\t"
      "mov %[carry], r1\n\t"
      "brcc 2f\n\t"
      "inc %[carry]\n"
      "2: mul %C[value], %[ten]\n\t"
      "add r0, %[carry]\n\t"
      "mov %C[value], r0\n\t"
      "mov %[carry], r1\n\t"
      "brcc 3f\n\t"
      "inc %[carry]\n"
      "3: mul %D[value], %[ten]\n\t"
      "add r0, %[carry]\n\t"
      "mov %D[value], r0\n\t"
      "clr r1"
      : [value] "+r"(value), [carry] "+r"(carry), [ten] "=&d"(ten));
  return value;
#else
  return (((value << 2) + value) << 1) + digit;
#endif
}

}  // namespace detail

template <size_t Capacity>
__attribute__((always_inline)) inline FeedResult Decoder<Capacity>::feed(ByteView bytes) {
  // The common case inline, the caller straight into the run: a message in one span ends in it (a
  // wrapper's own call and register saves cost a B drive ~70 AVR cycles).
  const uint8_t* const begin = bytes.data();
  const uint8_t* const end = begin + bytes.size();
  const RunEnd ran = run(begin, end);
  if (ran.frame) return FeedResult{DecodeStatus::frame, static_cast<size_t>(ran.next - begin)};
  if (ran.next == end) return FeedResult{DecodeStatus::more, bytes.size()};
  return feed_after_run(bytes, ran.next);
}

template <size_t Capacity>
__attribute__((noinline)) FeedResult Decoder<Capacity>::feed_after_run(ByteView bytes, const uint8_t* next) {
  const uint8_t* const begin = bytes.data();
  const uint8_t* const end = begin + bytes.size();
  for (;;) {
    const uint8_t byte = *next++;
    // The line end of a message goes straight to finish(): what feed(byte) does with it in these states
    // (at any size), without its dispatch.
    const DecodeStatus status = byte == '\n' && (state_ == State::lcurly || state_ == State::trailer)
                                    ? finish()
                                    : feed_outside_run(byte);
    if (status != DecodeStatus::more) return FeedResult{status, static_cast<size_t>(next - begin)};
    if (next == end) break;
    const RunEnd ran = run(next, end);
    next = ran.next;
    if (ran.frame) return FeedResult{DecodeStatus::frame, static_cast<size_t>(next - begin)};
    if (next == end) break;
  }
  return FeedResult{DecodeStatus::more, bytes.size()};
}

template <size_t Capacity>
__attribute__((noinline)) DecodeStatus Decoder<Capacity>::feed_outside_run(uint8_t byte) {
  return feed(byte);
}

// The AVR images are built -Os; feed(bytes)'s run alone at -O2 costs a B segment 124 cycles less (the
// loops laid out for speed; ~100 bytes more flash). The host keeps its build's level.
#if defined(__AVR__)
#define TETHER_ELCANO_RUN_OPTIMIZE optimize("O2"),
#else
#define TETHER_ELCANO_RUN_OPTIMIZE
#endif

template <size_t Capacity>
__attribute__((TETHER_ELCANO_RUN_OPTIMIZE noinline)) typename Decoder<Capacity>::RunEnd Decoder<Capacity>::run(
    const uint8_t* next, const uint8_t* end) {
  // Exactly what feed(byte) does with these bytes, as straight-line code: where the code is says which
  // state the message is in (a label per state), the write cursor, the number and its digit count live in
  // registers, and the members are written back once, when the run stops (a state variable
  // dispatched per byte and the members' loads and stores cost more on the AVR than the parsing). It
  // stops before any byte it does not take (`\n`, a tenth digit, anything unusual), so that feed(byte)
  // sees that byte with the members in step. Each byte keeps at most one: limiting the run to the room
  // left keeps every write inside the buffer without a check per byte (the byte that would not fit goes
  // through feed(byte), which reports it). Its own function without calls, and the number in 16 bits up
  // to 4 digits (beyond, in value_): on the AVR its values then fit in registers (inlined into feed(bytes),
  // or calling start(), they went to the stack and back on every byte).
  const size_t room = Capacity - size_;
  if (static_cast<size_t>(end - next) > room) end = next + room;
  uint8_t* out = buffer_ + size_;
  uint8_t byte = 0;
  uint8_t digit = 0;
  uint8_t offset = field_;
  bool negative = negative_;
  uint8_t digits = digits_;
  uint16_t small = static_cast<uint16_t>(value_);  // the number while it has at most 4 digits
  int32_t number = 0;
  switch (state_) {
    case State::header: goto header;
    case State::lcurly: goto lcurly;
    case State::letter: goto letter;
    case State::number: goto number;
    case State::trailer: goto trailer;
    case State::skip: return RunEnd{next, false};  // feed(byte)'s
  }
  return RunEnd{next, false};

header:
  if (next == end) goto stop_header;
  byte = *next;
  if (byte == ' ' || byte == '\n') {  // an empty line is nothing (rule 1, step())
    ++next;
    goto header;
  }
  if (!detail::is_header(byte)) goto stop_header;
  open(byte);  // keeps the header: the buffer starts over
  ++next;
  out = buffer_ + 1;

lcurly:
  if (next == end) goto stop_lcurly;
  byte = *next;
  if (byte == '{') {
    detail::store_next(out, byte);
    ++next;
    goto letter;
  }
  if (byte == ' ') {
    ++next;
    goto lcurly;
  }
  if (byte == '\n' && generation_ == Generation::b && detail::required_fields_set(message_)) {
    // A generation B message is complete: what finish() does then, here. The '\n' fits: the run keeps
    // at most one byte per byte and stops at the room left, so a byte it reads has room.
    detail::store_next(out, byte);
    ++next;
    // The counter's carry loop (~10 AVR cycles; an inline 32-bit `++` through the pointer is ~24), inline
    // as in an interrupt handler: a call to add_one would make the run save more registers.
    add_one_in_interrupt(counters_->frames_ok);
    fields_ = detail::fields_set(message_.type, attributes_);
    state_ = State::header;
    size_ = static_cast<size_t>(out - buffer_);
    return RunEnd{next, true};
  }
  if (generation_ != Generation::d || static_cast<uint8_t>(byte - '0') >= 10 || out == buffer_ + 1) {
    goto stop_lcurly;
  }
  crc_end_ = static_cast<size_t>(out - buffer_);  // the generation D trailer starts
  trailer_ = 0;

trailer:
  if (next == end) goto stop_trailer;
  byte = *next;
  digit = static_cast<uint8_t>(byte - '0');
  if (digit < 10 && trailer_ <= 25) {  // beyond: feed(byte) reports bad_crc
    trailer_ = static_cast<uint16_t>(trailer_ * 10u + digit);
    trailer_digits_ = true;
    detail::store_next(out, byte);
    ++next;
    goto trailer;
  }
  if (byte != ' ') goto stop_trailer;
  ++next;
  goto trailer;

letter:
  if (next == end) goto stop_letter;
  byte = *next;
  if (byte == ' ') {
    ++next;
    goto letter;
  }
  offset = field_of(byte);
  // field_of has 0 for generation B `p` (two fields: E,N); every other 0 is an unknown letter.
  if (offset == 0) {
    if (byte != 'p' || generation_ != Generation::b) goto stop_letter;
    second_ = false;  // read only for `p` (field 0)
  }
  detail::store_next(out, byte);
  ++next;
  ++attributes_;
  negative = false;
  digits = 0;
  small = 0;

number:
  if (next == end) goto stop_number;
  byte = *next;
  digit = static_cast<uint8_t>(byte - '0');
  if (digit < 10) {
    if (digits < 4) {
      // Below 1000 so far: 4 digits fit in 16 bits (9999). small * 10 as (small * 5) * 2: on the AVR 10
      // cycles (the compiler's own shifts for * 10 take 13).
      small = static_cast<uint16_t>((((small << 2) + small) << 1) + digit);
    } else {
      if (digits >= kSafeDigits) goto stop_number;  // the range check is feed(byte)'s
      // Fewer than 9 digits so far: one more stays in int32 (a 32-bit multiply is a library call on the
      // AVR; times_ten_plus says how it is done there).
      value_ = detail::times_ten_plus(digits == 4 ? small : value_, digit);
    }
    ++digits;
    detail::store_next(out, byte);
    ++next;
    goto number;
  }
  if (byte == '}') {
    if (digits == 0) goto stop_number;
    number = value_of(digits, small, negative);
    if (offset != 0) {
      *field(offset) = number;
    } else if (second_) {  // generation B `p E,N` (field_of has no single field for it)
      // N first: E's copy can then take N's registers (E first kept four more registers, saved and restored
      // on every run on the AVR).
      message_.north = number;
      message_.east = first_;
    } else {
      goto stop_number;  // `{p E}` without N: feed(byte)'s bad_number
    }
    detail::store_next(out, byte);
    ++next;
    goto lcurly;
  }
  if (byte == ' ') {
    ++next;
    goto number;
  }
  if (byte == '-' && digits == 0 && !negative) {
    negative = true;
  } else if (byte == ',' && offset == 0 && !second_ && digits != 0) {
    // Generation B `p E,N`: E is kept while N is read (field 0 in generation B means `p`).
    first_ = value_of(digits, small, negative);
    second_ = true;
    negative = false;
    digits = 0;
    small = 0;
  } else {
    goto stop_number;
  }
  detail::store_next(out, byte);
  ++next;
  goto number;

stop_header:
  state_ = State::header;
  goto stop;
stop_lcurly:
  state_ = State::lcurly;
  goto stop;
stop_trailer:
  state_ = State::trailer;
  goto stop;
stop_letter:
  state_ = State::letter;
  goto stop;
stop_number:
  state_ = State::number;
stop:
  field_ = offset;
  negative_ = negative;
  digits_ = digits;
  if (digits <= 4) value_ = small;
  size_ = static_cast<size_t>(out - buffer_);
  return RunEnd{next, false};
}

template <size_t Capacity>
__attribute__((always_inline)) inline int32_t Decoder<Capacity>::value_of(uint8_t digits, uint16_t small, bool negative) const {
  // The magnitude is <= 2^31 when negative, <= 2^31 - 1 otherwise: both fit once the sign is applied.
  const uint32_t value = digits <= 4 ? small : value_;
  return negative ? static_cast<int32_t>(0u - value) : static_cast<int32_t>(value);
}

template <size_t Capacity>
bool Decoder<Capacity>::keep(uint8_t byte) {
  if (size_ == Capacity) return false;
  buffer_[size_++] = byte;
  return true;
}

template <size_t Capacity>
int32_t Decoder<Capacity>::signed_value() const {
  // value_ <= 2^31 when negative, <= 2^31 - 1 otherwise: both fit once the sign is applied.
  return negative_ ? static_cast<int32_t>(0u - value_) : static_cast<int32_t>(value_);
}

template <size_t Capacity>
bool Decoder<Capacity>::store_value() {
  const int32_t value = signed_value();
  if (field_ != 0) {
    *field(field_) = value;
  } else if (second_) {  // generation B `p E,N`
    message_.east = first_;
    message_.north = value;
  } else {
    return false;  // generation B `p` needs both values
  }
  return true;
}

template <size_t Capacity>
DecodeStatus Decoder<Capacity>::fail(Error error) {
  error_ = error;
  if (error == Error::bad_crc) {
    add_one(counters_->crc_errors);
  } else if (error == Error::too_long) {
    add_one(counters_->oversize_frames);
  } else {
    add_one(counters_->framing_errors);
  }
  state_ = State::skip;
  size_ = 0;
  return DecodeStatus::error;
}

template <size_t Capacity>
DecodeStatus Decoder<Capacity>::fail_at_line_end(Error error) {
  fail(error);
  state_ = State::header;  // the line ended with the error: nothing is left to skip, no resync
  return DecodeStatus::error;
}

template <size_t Capacity>
DecodeStatus Decoder<Capacity>::finish() {
  if (generation_ == Generation::d) {
    if (!trailer_digits_) return fail_at_line_end(Error::bad_crc);
    if (trailer_ != Crc8Smbus::compute(ByteView(buffer_, crc_end_))) return fail_at_line_end(Error::bad_crc);
  }
  if (!detail::required_fields_set(message_)) return fail_at_line_end(Error::inval_comb);
  if (!keep('\n')) return fail_at_line_end(Error::too_long);
  ++counters_->frames_ok;
  fields_ = detail::fields_set(message_.type, attributes_);
  state_ = State::header;
  return DecodeStatus::frame;
}

template <size_t Capacity>
__attribute__((noinline)) void Decoder<Capacity>::start(uint8_t header) {
  open(header);
  size_ = 1;
  state_ = State::lcurly;
}

template <size_t Capacity>
__attribute__((always_inline)) inline void Decoder<Capacity>::open(uint8_t header) {
  // Field by field: `message_ = Message()` builds, clears and copies a temporary (~450 AVR cycles a
  // message). The assertion keeps this in step with Message: type, then exactly these eight int32.
  static_assert(offsetof(Message, north) == offsetof(Message, number) + 7 * sizeof(int32_t) &&
                    sizeof(Message) <= offsetof(Message, north) + 2 * sizeof(int32_t),
                "Decoder::open clears every field of Message");
  // Only the fields the last message may have set (fields_; the others are kUnset already): a drive's
  // two (the usual message on a ring) or all eight; a test per field would cost more than its stores.
  message_.speed = kUnset;
  message_.angle = kUnset;
  if ((fields_ & ~(field_bits::speed | field_bits::angle)) != 0) {
    message_.number = kUnset;
    message_.obstacle = kUnset;
    message_.bearing = kUnset;
    message_.probability = kUnset;
    message_.east = kUnset;
    message_.north = kUnset;
  }
  fields_ = field_bits::all;  // until this message completes
  attributes_ = 0;
  message_.type = static_cast<Type>(header);
  buffer_[0] = header;  // size_ 1: run() keeps the size in its cursor, start() sets it
  trailer_digits_ = false;  // trailer_ is reset where a trailer starts
}

template <size_t Capacity>
__attribute__((noinline)) DecodeStatus Decoder<Capacity>::feed_slow(uint8_t byte) {
  const bool was_open = in_frame();
  const DecodeStatus status = step(byte);
  // A header never appears inside a message: one arriving mid-message (the sender reset, bytes were
  // lost) ends the broken message with its error AND starts the next message, which must not be lost.
  if (status == DecodeStatus::error && was_open && detail::is_header(byte)) {
    state_ = State::header;
    add_one(counters_->resyncs);
    step(byte);  // opens the message; cannot produce an event
  } else if (status == DecodeStatus::error && byte == '\n') {
    state_ = State::header;  // a line end that broke a message (`D{s1\n`) also ended it: nothing to skip
  }
  return status;
}

template <size_t Capacity>
DecodeStatus Decoder<Capacity>::step(uint8_t byte) {
  if (detail::is_ignored(byte)) return DecodeStatus::more;
  if (state_ == State::skip) {
    if (byte == '\n') {
      state_ = State::header;
      add_one(counters_->resyncs);
      return DecodeStatus::more;
    }
    if (!detail::is_header(byte)) return DecodeStatus::more;
    add_one(counters_->resyncs);
    state_ = State::header;  // and read this byte as the header below
  }
  switch (state_) {
    case State::header:
      if (byte == '\n') return DecodeStatus::more;  // an empty line
      if (!detail::is_header(byte)) return fail(Error::bad_type);
      start(byte);
      return DecodeStatus::more;
    case State::lcurly:
      if (byte == '\n') return finish();
      if (byte == '{') {
        if (!keep(byte)) return fail(Error::too_long);
        state_ = State::letter;
        return DecodeStatus::more;
      }
      if (generation_ == Generation::d && byte >= '0' && byte <= '9' && size_ > 1) {
        crc_end_ = size_;
        trailer_ = 0;
        state_ = State::trailer;
        return step(byte);
      }
      return fail(Error::bad_lcurly);
    case State::letter: {
      const bool known = byte == 'n' || byte == 's' || byte == 'a' || byte == 'b' || byte == 'r' || byte == 'p' ||
                         (generation_ == Generation::d && (byte == 'o' || byte == 'q'));
      if (!known) return fail(Error::bad_attrib);
      if (!keep(byte)) return fail(Error::too_long);
      begin_number(field_of(byte));
      return DecodeStatus::more;
    }
    case State::number:
      if (byte == '-' && !digits_ && !negative_) {
        negative_ = true;
      } else if (byte >= '0' && byte <= '9') {
        if (digits_ != 0xFF) ++digits_;
        // int32 range: beyond it an error, never a wrap (the reference wraps). 2147483647 is read: it is
        // the "unset" marker, so the field stays unset, as in the reference (a required one: inval_comb).
        // Checked before multiplying, by comparison only (a 32-bit division costs hundreds of AVR cycles).
        const uint8_t digit = static_cast<uint8_t>(byte - '0');
        if (value_ > 214748364u || (value_ == 214748364u && digit > (negative_ ? 8u : 7u))) {
          return fail(Error::bad_number);
        }
        value_ = (value_ << 3) + (value_ << 1) + digit;  // * 10 without a 32-bit multiply call
      } else if (byte == ',' && field_ == 0 && !second_ && digits_) {  // field 0: generation B `p`
        first_ = signed_value();
        second_ = true;
        negative_ = false;
        digits_ = 0;
        value_ = 0;
      } else if (byte == '}' && digits_) {
        if (!store_value()) return fail(Error::bad_number);
        if (!keep(byte)) return fail(Error::too_long);
        state_ = State::lcurly;
        return DecodeStatus::more;
      } else {
        return fail(Error::bad_number);
      }
      if (!keep(byte)) return fail(Error::too_long);
      return DecodeStatus::more;
    case State::trailer:
      if (byte == '\n') return finish();
      if (byte < '0' || byte > '9' || trailer_ > 25) return fail(Error::bad_crc);
      trailer_ = static_cast<uint16_t>(trailer_ * 10u + static_cast<uint8_t>(byte - '0'));
      trailer_digits_ = true;
      if (!keep(byte)) return fail(Error::too_long);
      return DecodeStatus::more;
    case State::skip:
      break;
  }
  return DecodeStatus::more;
}

}  // namespace elcano
}  // namespace tether

#undef TETHER_ELCANO_RUN_OPTIMIZE
