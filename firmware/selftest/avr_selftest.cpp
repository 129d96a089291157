// AVR selftest: runs the portable core on the real MCU model (simavr) and reports over UART0.
//   1. CRC check values with the avr-libc back end.
//   2. CRCs of pseudo-random buffers (seed from EEPROM bytes 0..3) for the host to compare with Boost.
//   3. The device half of the session engine (duplicate filter, partial-frame deadline, failsafe watchdog)
//      and the host half's 8-bit id wrap, with 16-bit int arithmetic.
//   4. The proxy frame decoder's run path (its AVR assembly) against its per-byte path, on pseudo-random
//      frames with zeros, damage and oversize ones, fed in runs of every length.
//   5. `add_one_in_interrupt` (assembly): the carry through every byte, the 2^32 wrap, nothing beside touched.
//   6. The proxy frame writer's CRC-16 frames (their AVR assembly loop) against COBS of the CRC and the
//      payload written plainly, on pseudo-random payloads of 0..260 bytes: no zeros (full blocks), few,
//      many, with and without the leading delimiter.
//   7. The Romi decoder's body run (its AVR assembly) against its per-byte path, on pseudo-random request,
//      manual and log frames with damage (special bytes put in, cut short, garbage between frames) and
//      oversize ones, fed in runs of every length.
//   8. The Elcano decoder's run (its AVR assembly for a number's fifth to ninth digit) against its per-byte
//      path, generations B and D, on pseudo-random messages with numbers of 1 to 10 digits, damage and
//      oversize ones, fed in runs of every length; the required-field test's AVR top-byte shortcut against
//      the plain comparison, on values around the unset marker, and on drives read whole.
// Ends with "selftest end failures=N", then sleeps with interrupts off (simavr stops there).
// Uses a polled UART on purpose: it must not depend on the firmware runtime it helps to validate.
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "selftest_sequence.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/crc.hpp"
#include "tether/core/session/duplicate_filter.hpp"
#include "tether/core/session/failsafe_watchdog.hpp"
#include "tether/core/session/partial_frame_deadline.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/proxy/cobs.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/romi/decoder.hpp"

namespace {

void uart_init() {
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(TXEN0);
  UBRR0H = 0;
  UBRR0L = 16;  // 115200 at 16 MHz with U2X; written last (simavr recomputes the baud rate on UBRR0L)
}
void put(char c) {
  while ((UCSR0A & _BV(UDRE0)) == 0) {
  }
  UDR0 = static_cast<uint8_t>(c);
}
void put(const char* text) {
  while (*text != '\0') put(*text++);
}
void put_hex(uint32_t value, uint8_t digits) {
  static const char kHex[] = "0123456789abcdef";
  for (int8_t shift = static_cast<int8_t>((digits - 1) * 4); shift >= 0; shift = static_cast<int8_t>(shift - 4)) {
    put(kHex[(value >> shift) & 0xFu]);
  }
}

uint8_t failures = 0;
void report(const char* name, bool ok) {
  put("engine ");
  put(name);
  put(ok ? " ok\n" : " fail\n");
  if (!ok) ++failures;
}

void check_crc_values() {
  const tether::ByteView check = tether::ByteView::from_literal("123456789");
  put("backend ");
  put(tether::crc_backend_name());
  put("\ncheck crc8 ");
  put_hex(tether::Crc8Smbus::compute(check), 2);
  put(" crc16 ");
  put_hex(tether::Crc16Mcrf4xx::compute(check), 4);
  put("\n");
}

void checksum_random_buffers(uint32_t seed) {
  tether::selftest::Xorshift32 random(seed);
  for (uint8_t index = 0; index < tether::selftest::kBufferCount; ++index) {
    const uint16_t length = random.next_length();
    tether::Crc8Smbus crc8;
    tether::Crc16Mcrf4xx crc16;
    for (uint16_t i = 0; i < length; ++i) {
      const uint8_t byte = random.next_byte();
      crc8.update(byte);
      crc16.update(byte);
    }
    put("buf ");
    put_hex(index, 2);
    put(" ");
    put_hex(length, 4);
    put(" ");
    put_hex(crc8.value(), 2);
    put(" ");
    put_hex(crc16.value(), 4);
    put("\n");
  }
}

void check_duplicate_filter() {
  tether::LinkCounters counters;
  tether::session::DuplicateFilter<uint8_t, 1, 64> filter(counters);
  bool ok = !filter.check(255, 7).duplicate;  // B6: a fresh device knows no id, not even 255
  const tether::ByteView reply = tether::ByteView::from_literal("#a[0]:ffxx\r\n");
  ok = ok && filter.remember(255, 7, reply) == tether::Status::ok;
  const auto again = filter.check(255, 7);
  ok = ok && again.duplicate && again.cached_reply.equals(reply) && counters.duplicates == 1;
  ok = ok && !filter.check(255, 8).duplicate;
  report("duplicate_filter", ok);
}

void check_watchdog() {
  tether::LinkCounters counters;
  tether::session::FailsafeWatchdog watchdog(10000, counters);
  watchdog.start(0xFFFFF000u);  // silence limit crosses the 32-bit wrap
  bool ok = !watchdog.poll(0x170Fu) && watchdog.poll(0x1710u) && watchdog.triggered();
  ok = ok && !watchdog.poll(0x2000u) && counters.failsafes == 1;
  report("failsafe_watchdog", ok);
}

void check_partial_frame() {
  tether::LinkCounters counters;
  tether::session::PartialFrameDeadline deadline(1000, counters);
  deadline.on_frame_start(64000u);
  const bool ok = !deadline.poll(64999u) && deadline.poll(65000u) && !deadline.poll(65001u) &&
                  counters.partial_timeouts == 1;
  report("partial_frame_deadline", ok);
}

struct ByteIdPolicy {
  using Id = uint8_t;
  using Code = int16_t;
  static bool is_success(Code code) { return code >= 0; }
  static bool is_retryable(Code code) { return code < 0 && code >= -6; }
};

void check_request_ids() {
  tether::LinkCounters counters;
  tether::session::CallTiming timing;
  tether::session::RequestTable<ByteIdPolicy, 1> table(timing, 255, counters);
  bool ok = true;
  for (uint16_t call = 0; call < 300 && ok; ++call) {
    const auto id = table.begin(call);
    ok = id.ok() && id.value() == static_cast<uint8_t>(call) &&
         table.on_reply(id.value(), 0, call).completion.outcome == tether::session::CallOutcome::ok;
  }
  report("request_ids", ok);
}

// One decoder event, compared between the two paths: status, error or the frame's size and CRC-16.
struct ProxyEvent {
  uint8_t status;
  uint8_t detail;
  uint16_t digest;
  bool operator!=(const ProxyEvent& other) const {
    return status != other.status || detail != other.detail || digest != other.digest;
  }
};

template <typename Decoder>
ProxyEvent proxy_event(tether::DecodeStatus status, const Decoder& decoder) {
  ProxyEvent event{static_cast<uint8_t>(status), 0, 0};
  if (status == tether::DecodeStatus::frame) {
    event.detail = static_cast<uint8_t>(decoder.frame().size());
    event.digest = tether::Crc16Mcrf4xx::compute(decoder.frame());
  } else if (status == tether::DecodeStatus::error) {
    event.detail = static_cast<uint8_t>(decoder.error());
  }
  return event;
}

// Feeds `wire` to `by_run` in runs of 1-48 bytes (lengths from `random`): true when every run was taken a
// byte or more at a time and the events were exactly `expected` (the per-byte decoder's), in order.
template <typename Decoder, typename Event>
bool runs_give(tether::selftest::Xorshift32& random, const uint8_t* wire, uint8_t size, Decoder& by_run,
               const Event* expected, uint8_t events, Event (*event_of)(tether::DecodeStatus, const Decoder&)) {
  bool ok = true;
  uint8_t seen = 0;
  uint8_t at = 0;
  while (at < size && ok) {
    uint8_t end = static_cast<uint8_t>(at + 1u + random.next() % 48u);
    if (end > size) end = size;
    while (at < end && ok) {
      const tether::FeedResult fed = by_run.feed(tether::ByteView(wire + at, static_cast<size_t>(end - at)));
      ok = fed.consumed >= 1 && fed.consumed <= static_cast<size_t>(end - at);
      at = static_cast<uint8_t>(at + fed.consumed);
      if (fed.status != tether::DecodeStatus::more) {
        ok = ok && seen < events && !(event_of(fed.status, by_run) != expected[seen]);
        ++seen;
      }
    }
  }
  return ok && seen == events;
}

// The counters of the per-byte and the run-fed decoder agree.
bool same_counters(const tether::LinkCounters& a, const tether::LinkCounters& b) {
  return a.frames_ok == b.frames_ok && a.crc_errors == b.crc_errors && a.framing_errors == b.framing_errors &&
         a.oversize_frames == b.oversize_frames && a.resyncs == b.resyncs;
}

void check_proxy_runs(uint32_t seed) {
  using tether::proxy::Integrity;
  tether::selftest::Xorshift32 random(seed ^ 0x5A5A5A5Au);
  bool ok = true;
  uint16_t frames = 0;
  for (uint8_t round = 0; round < 24 && ok; ++round) {
    const Integrity integrity = round % 3 == 2 ? Integrity::none : Integrity::crc16;
    uint8_t wire[160];
    uint8_t size = 0;
    while (true) {  // frames until the buffer is full: payloads of 0..52 bytes (the decoders hold 40)
      uint8_t payload[52];
      const uint8_t length = static_cast<uint8_t>(random.next() % (sizeof payload + 1));
      for (uint8_t i = 0; i < length; ++i) payload[i] = random.next() % 4 == 0 ? 0 : random.next_byte();
      uint8_t frame[64];
      const auto framed = tether::proxy::encode_frame(tether::ByteView(payload, length), integrity,
                                                      random.next() % 2 == 0, tether::MutableByteView(frame));
      if (!framed.ok() || size + framed.value() > sizeof wire) break;
      uint8_t used = static_cast<uint8_t>(framed.value());
      const uint8_t damage = static_cast<uint8_t>(random.next() % 5);
      if (damage == 0) {
        const uint8_t at = static_cast<uint8_t>(random.next() % used);
        frame[at] = static_cast<uint8_t>(frame[at] ^ (1u + random.next() % 255u));
      }
      if (damage == 1) used = static_cast<uint8_t>(random.next() % used);  // cut short
      for (uint8_t i = 0; i < used; ++i) wire[size++] = frame[i];
    }
    tether::LinkCounters byte_counters;
    tether::LinkCounters run_counters;
    tether::proxy::Decoder<40> by_byte(integrity, byte_counters);
    tether::proxy::Decoder<40> by_run(integrity, run_counters);
    ProxyEvent expected[48];
    uint8_t events = 0;
    for (uint8_t i = 0; i < size && events < 48; ++i) {
      const tether::DecodeStatus status = by_byte.feed(wire[i]);
      if (status != tether::DecodeStatus::more) expected[events++] = proxy_event(status, by_byte);
    }
    ok = runs_give(random, wire, size, by_run, expected, events, &proxy_event) &&
         same_counters(run_counters, byte_counters) && by_run.in_frame() == by_byte.in_frame();
    frames = static_cast<uint16_t>(frames + byte_counters.frames_ok);
  }
  report("proxy_runs", ok && frames > 24);  // most rounds deliver frames: the check compared something
}

// One Romi decoder event, compared between the two paths: status, the error or the frame's payload size and
// CRC-16, its flags, id and opcode.
struct RomiEvent {
  uint8_t status;
  uint8_t detail;
  uint16_t digest;
  uint8_t flags;
  uint8_t id;
  char opcode;
  bool operator!=(const RomiEvent& other) const {
    return status != other.status || detail != other.detail || digest != other.digest || flags != other.flags ||
           id != other.id || opcode != other.opcode;
  }
};

template <typename Decoder>
RomiEvent romi_event(tether::DecodeStatus status, const Decoder& decoder) {
  const tether::romi::Frame& frame = decoder.frame();
  RomiEvent event{static_cast<uint8_t>(status), 0, 0,
                  static_cast<uint8_t>((frame.log ? 1 : 0) | (frame.manual ? 2 : 0) | (frame.has_id ? 4 : 0)),
                  frame.id, frame.opcode};
  if (status == tether::DecodeStatus::frame) {
    event.detail = static_cast<uint8_t>(frame.payload.size());
    event.digest = tether::Crc16Mcrf4xx::compute(frame.payload);
  } else {
    event.detail = static_cast<uint8_t>(decoder.error());
  }
  return event;
}

// A Romi frame into `out`: a request (opcode, body of digits, brackets, commas, quotes, spaces and now and
// then a ':'), a manual one (`xxxx`) or a log line, with its id and CRC; returns its size.
uint8_t romi_frame(tether::selftest::Xorshift32& random, uint8_t* out) {
  static const char kBody[] = "0123456789[],-\" !azAZ?:";
  uint8_t size = 0;
  out[size++] = '#';
  const uint8_t kind = static_cast<uint8_t>(random.next() % 4);  // 0, 1: request, 2: manual, 3: log
  if (kind == 3) out[size++] = '!';
  out[size++] = static_cast<uint8_t>("aeZ9?_"[random.next() % 6]);
  const uint8_t length = static_cast<uint8_t>(random.next() % 40);  // the decoder below holds 32
  for (uint8_t i = 0; i < length; ++i) out[size++] = static_cast<uint8_t>(kBody[random.next() % (sizeof kBody - 1)]);
  out[size++] = ':';
  static const char kHex[] = "0123456789abcdef";
  if (kind == 2) {
    for (uint8_t i = 0; i < 4; ++i) out[size++] = 'x';
  } else {
    const uint8_t id = random.next_byte();
    out[size++] = static_cast<uint8_t>(kHex[id >> 4]);
    out[size++] = static_cast<uint8_t>(kHex[id & 0xF]);
    const uint8_t crc = tether::Crc8Smbus::compute(tether::ByteView(out, size));
    out[size++] = static_cast<uint8_t>(kHex[crc >> 4]);
    out[size++] = static_cast<uint8_t>(kHex[crc & 0xF]);
  }
  out[size++] = '\r';
  out[size++] = '\n';
  return size;
}

void check_romi_runs(uint32_t seed) {
  tether::selftest::Xorshift32 random(seed ^ 0x52304D49u);
  bool ok = true;
  uint16_t frames = 0;
  uint16_t errors = 0;
  for (uint8_t round = 0; round < 32 && ok; ++round) {
    uint8_t wire[200];
    uint8_t size = 0;
    while (true) {  // frames until the buffer is full
      uint8_t frame[64];
      uint8_t used = romi_frame(random, frame);
      if (static_cast<unsigned int>(size + used) + 2u > sizeof wire) break;
      const uint8_t damage = static_cast<uint8_t>(random.next() % 6);
      if (damage == 0) frame[1 + random.next() % (used - 1u)] = static_cast<uint8_t>("#\r\n:x"[random.next() % 5]);
      if (damage == 1) used = static_cast<uint8_t>(1 + random.next() % used);  // cut short
      if (damage == 2) wire[size++] = static_cast<uint8_t>("z\n#"[random.next() % 3]);  // garbage before it
      for (uint8_t i = 0; i < used; ++i) wire[size++] = frame[i];
    }
    tether::LinkCounters byte_counters;
    tether::LinkCounters run_counters;
    tether::romi::Decoder<32> by_byte(byte_counters);
    tether::romi::Decoder<32> by_run(run_counters);
    RomiEvent expected[24];
    uint8_t events = 0;
    for (uint8_t i = 0; i < size && events < 24; ++i) {
      const tether::DecodeStatus status = by_byte.feed(wire[i]);
      if (status != tether::DecodeStatus::more) expected[events++] = romi_event(status, by_byte);
    }
    ok = runs_give(random, wire, size, by_run, expected, events, &romi_event) &&
         same_counters(run_counters, byte_counters) && by_run.in_frame() == by_byte.in_frame();
    frames = static_cast<uint16_t>(frames + byte_counters.frames_ok);
    errors = static_cast<uint16_t>(errors + byte_counters.framing_errors + byte_counters.oversize_frames +
                                   byte_counters.crc_errors);
  }
  report("romi_runs", ok && frames > 32 && errors > 32);  // both kinds of event were compared
}

// What an Elcano decoder reported: the status, then the error or the message, its field bits and a digest of
// its forwarded bytes.
struct ElcanoEvent {
  uint8_t status;
  uint8_t error;
  uint8_t type;
  uint8_t fields;
  uint16_t forward;  // size << 8 ^ CRC-8 of the bytes
  uint16_t values;   // CRC-16 of the message's eight values
  bool operator!=(const ElcanoEvent& other) const {
    return status != other.status || error != other.error || type != other.type || fields != other.fields ||
           forward != other.forward || values != other.values;
  }
};

template <typename Decoder>
ElcanoEvent elcano_event(tether::DecodeStatus status, const Decoder& decoder) {
  ElcanoEvent event{static_cast<uint8_t>(status), 0, 0, 0, 0, 0};
  if (status == tether::DecodeStatus::error) {
    event.error = static_cast<uint8_t>(decoder.error());
  } else {
    const tether::elcano::Message& m = decoder.frame();
    const int32_t values[] = {m.number, m.speed, m.angle, m.obstacle, m.bearing, m.probability, m.east, m.north};
    event.type = static_cast<uint8_t>(m.type);
    event.fields = decoder.fields();
    event.values = tether::Crc16Mcrf4xx::compute(tether::ByteView(reinterpret_cast<const uint8_t*>(values), sizeof values));
    event.forward = static_cast<uint16_t>((decoder.forward().size() << 8) ^ tether::Crc8Smbus::compute(decoder.forward()));
  }
  return event;
}

// Values whose bytes cross the unset marker's (0x7FFFFFFF): the top byte 0x7F with the others not all
// ones, the marker itself, the int32 ends and one past them (bad_number).
const char* const kElcanoEdgeNumbers[] = {"2147483647", "2147483646", "2130706432", "2147483392", "2147483648",
                                          "-2147483648", "-2147483649", "16777215", "2113929215", "999999999",
                                          "1000000000", "4294967295"};

// Appends the generation D trailer of the `size` bytes at `out` (a wrong one if `wrong`); returns the size.
uint8_t elcano_trailer(uint8_t* out, uint8_t size, bool wrong) {
  uint8_t crc = tether::Crc8Smbus::compute(tether::ByteView(out, size));
  if (wrong) crc = static_cast<uint8_t>(crc + 1);
  if (crc >= 100) out[size++] = static_cast<uint8_t>('0' + crc / 100);
  if (crc >= 10) out[size++] = static_cast<uint8_t>('0' + crc / 10 % 10);
  out[size++] = static_cast<uint8_t>('0' + crc % 10);
  return size;
}

// One Elcano message of `generation` (a drive most often): attributes with numbers of 1 to 10 digits
// (edge values now and then), spaces in generation B, its CRC-8 trailer in generation D (wrong now and then).
uint8_t elcano_message(tether::selftest::Xorshift32& random, tether::elcano::Generation generation, uint8_t* out) {
  const bool b = generation == tether::elcano::Generation::b;
  uint8_t size = 0;
  const uint8_t type = static_cast<uint8_t>(random.next() % 7);
  out[size++] = static_cast<uint8_t>("DDDDSGX"[type]);
  // Half the messages carry their type's required attributes, in order; the others 0 to 5 random ones.
  static const char* const kRequired[] = {"sa", "sa", "sa", "sa", "sabpq", "nbpq", "nsbpq"};
  const char* required = random.next() % 2 == 0 ? kRequired[type] : nullptr;
  const uint8_t attributes = required != nullptr ? static_cast<uint8_t>(__builtin_strlen(required) - (b && type > 3 ? 1 : 0))
                                                 : static_cast<uint8_t>(random.next() % 6);
  for (uint8_t a = 0; a < attributes && size < 64; ++a) {  // an attribute adds at most 48 bytes: 128 hold it
    out[size++] = '{';
    const uint8_t letter = static_cast<uint8_t>(required != nullptr ? required[a]
                                                : b ? "sasanbrpz"[random.next() % 9]
                                                    : "sasanbrpqoz"[random.next() % 11]);
    out[size++] = letter;
    const uint8_t numbers = b && letter == 'p' ? 2 : 1;
    for (uint8_t n = 0; n < numbers; ++n) {
      if (n != 0) out[size++] = ',';
      if (b && random.next() % 4 == 0) out[size++] = ' ';
      if (random.next() % 8 == 0) {
        for (const char* edge = kElcanoEdgeNumbers[random.next() % (sizeof kElcanoEdgeNumbers / sizeof kElcanoEdgeNumbers[0])];
             *edge != '\0'; ++edge) {
          out[size++] = static_cast<uint8_t>(*edge);
        }
      } else {
        if (random.next() % 4 == 0) out[size++] = '-';
        const uint8_t digits = static_cast<uint8_t>(1 + random.next() % (required != nullptr ? 9 : 10));
        for (uint8_t d = 0; d < digits; ++d) {
          out[size++] = static_cast<uint8_t>('0' + random.next() % 10);
          if (b && random.next() % 16 == 0) out[size++] = ' ';
        }
      }
    }
    out[size++] = '}';
  }
  if (!b) size = elcano_trailer(out, size, random.next() % 8 == 0);
  out[size++] = '\n';
  return size;
}

void check_elcano_runs(uint32_t seed) {
  tether::selftest::Xorshift32 random(seed ^ 0x454C4341u);
  bool ok = true;
  uint16_t frames = 0;
  uint16_t errors = 0;
  uint16_t long_numbers = 0;  // frames with a value of 5 or more digits: the assembly's
  for (uint8_t round = 0; round < 48 && ok; ++round) {
    const tether::elcano::Generation generation = round % 2 == 0 ? tether::elcano::Generation::b : tether::elcano::Generation::d;
    uint8_t wire[200];
    uint8_t size = 0;
    // Every round starts with a drive of long numbers, then a broken message: each kind of event is
    // compared whatever the seed; pseudo-random messages follow.
    const char* drive = generation == tether::elcano::Generation::b ? "D{s 123456789}{a -98765}" : "D{s123456789}{a-98765}";
    while (*drive != '\0') wire[size++] = static_cast<uint8_t>(*drive++);
    if (generation == tether::elcano::Generation::d) size = elcano_trailer(wire, size, false);
    for (const char* broken = "\nD{s 1x}\n"; *broken != '\0'; ++broken) wire[size++] = static_cast<uint8_t>(*broken);
    while (true) {  // messages until the buffer is full
      uint8_t message[128];
      uint8_t used = elcano_message(random, generation, message);
      if (static_cast<unsigned int>(size + used) + 2u > sizeof wire) break;
      const uint8_t damage = static_cast<uint8_t>(random.next() % 8);
      if (damage == 0) message[1 + random.next() % (used - 1u)] = static_cast<uint8_t>("{}\n-,D x"[random.next() % 9]);
      if (damage == 1) used = static_cast<uint8_t>(1 + random.next() % used);  // cut short
      if (damage == 2) wire[size++] = static_cast<uint8_t>("z\n "[random.next() % 3]);  // garbage before it
      for (uint8_t i = 0; i < used; ++i) wire[size++] = message[i];
    }
    tether::LinkCounters byte_counters;
    tether::LinkCounters run_counters;
    tether::elcano::Decoder<64> by_byte(generation, byte_counters);
    tether::elcano::Decoder<64> by_run(generation, run_counters);
    ElcanoEvent expected[24];
    uint8_t events = 0;
    for (uint8_t i = 0; i < size && events < 24; ++i) {
      const tether::DecodeStatus status = by_byte.feed(wire[i]);
      if (status == tether::DecodeStatus::more) continue;
      expected[events++] = elcano_event(status, by_byte);
      if (status != tether::DecodeStatus::frame) continue;
      const tether::elcano::Message& m = by_byte.frame();
      const int32_t values[] = {m.number, m.speed, m.angle, m.obstacle, m.bearing, m.probability, m.east, m.north};
      for (const int32_t value : values) {
        if (value != tether::elcano::kUnset && (value >= 10000 || value <= -10000)) {
          ++long_numbers;
          break;
        }
      }
    }
    ok = runs_give(random, wire, size, by_run, expected, events, &elcano_event) &&
         same_counters(run_counters, byte_counters) && by_run.in_frame() == by_byte.in_frame();
    frames = static_cast<uint16_t>(frames + byte_counters.frames_ok);
    errors = static_cast<uint16_t>(errors + byte_counters.framing_errors + byte_counters.oversize_frames +
                                   byte_counters.crc_errors);
  }
  // Both kinds of event were compared, long numbers among the frames (each round's first two messages).
  report("elcano_runs", ok && frames >= 48 && errors >= 48 && long_numbers >= 48);
}

// detail::is_set (on the AVR the top byte first) against the plain comparison; then drives read whole, the
// only type whose line end takes it: set unless exactly the marker.
void check_elcano_required_fields(uint32_t seed) {
  tether::selftest::Xorshift32 random(seed ^ 0x53455421u);
  bool ok = true;
  static const uint32_t kValues[] = {0u, 1u, 0xFFFFFFFFu, 0x7F000000u, 0x7FFFFFFEu, 0x7FFFFFFFu, 0x7EFFFFFFu,
                                     0x80000000u, 0xFF7FFFFFu, 0x007FFFFFu, 0x7FFF7FFFu, 0x7F7FFFFFu};
  for (uint16_t i = 0; i < 400 && ok; ++i) {
    uint32_t bits = i < sizeof kValues / sizeof kValues[0] ? kValues[i] : random.next();
    if (i >= 200) bits = (bits & 0x00FFFFFFu) | 0x7F000000u | (random.next() % 2 == 0 ? 0x00FFFF00u : 0u);
    const int32_t value = static_cast<int32_t>(bits);
    ok = tether::elcano::detail::is_set(value) == (value != tether::elcano::kUnset);
  }
  static const struct {
    const char* text;
    bool frame;
  } kDrives[] = {{"D{s 2147483647}{a 5}\n", false},  {"D{s 5}{a 2147483647}\n", false},
                 {"D{s 2147483646}{a 5}\n", true},   {"D{s 2130706432}{a 2147483392}\n", true},
                 {"D{s -1}{a 16777215}\n", true},    {"D{s 50}\n", false},
                 {"D{a 25}{s 2147483647}\n", false}, {"D{s 50}{a 25}\n", true}};
  tether::LinkCounters counters;
  tether::elcano::Decoder<64> decoder(tether::elcano::Generation::b, counters);
  for (const auto& drive : kDrives) {
    const tether::ByteView text = tether::ByteView(reinterpret_cast<const uint8_t*>(drive.text), __builtin_strlen(drive.text));
    const tether::FeedResult fed = decoder.feed(text);
    ok = ok && fed.consumed == text.size() &&
         fed.status == (drive.frame ? tether::DecodeStatus::frame : tether::DecodeStatus::error) &&
         (drive.frame || decoder.error() == tether::elcano::Error::inval_comb);
  }
  report("elcano_required_fields", ok);
}

// The frame writer against the frame built plainly: crc16 ‖ payload, COBS-encoded (cobs_encode: the C++
// loop), the delimiters around it. Payloads of 0..260 bytes of every zero density: none (blocks of 254
// bytes), 1 in 64, 1 in 4; the CRC itself is zero in a byte now and then (its patching's other cases).
// The buffers are on the stack, only while this runs (the 2 KB also hold the other checks' own).
void check_frame_encoder(uint32_t seed) {
  constexpr uint16_t kMaxLength = 260;
  uint8_t plain[2 + kMaxLength];  // crc16 ‖ payload
  uint8_t expected[tether::proxy::max_frame_size(kMaxLength)];
  uint8_t framed[sizeof expected];
  uint8_t* const payload = plain + 2;
  tether::selftest::Xorshift32 random(seed ^ 0xC0B5C0B5u);
  bool ok = true;
  for (uint8_t round = 0; round < 96 && ok; ++round) {
    const uint16_t length =
        round < 3 ? static_cast<uint16_t>(252u + round) : static_cast<uint16_t>(random.next() % (kMaxLength + 1u));
    const uint8_t zeros = static_cast<uint8_t>(round % 3 == 0 ? 0 : round % 3 == 1 ? 64 : 4);  // 1 in `zeros`
    for (uint16_t i = 0; i < length; ++i) {
      const uint8_t byte = random.next_byte();
      payload[i] = zeros != 0 && random.next() % zeros == 0 ? 0 : static_cast<uint8_t>(byte == 0 ? 1 : byte);
    }
    const bool lead = random.next() % 2 == 0;
    const uint16_t crc = tether::Crc16Mcrf4xx::compute(tether::ByteView(payload, length));
    plain[0] = static_cast<uint8_t>(crc & 0xFF);
    plain[1] = static_cast<uint8_t>(crc >> 8);
    size_t size = 0;
    if (lead) expected[size++] = 0;
    const auto cobs = tether::proxy::cobs_encode(tether::ByteView(plain, length + 2u),
                                                 tether::MutableByteView(expected + size, sizeof expected - size - 1));
    ok = cobs.ok();
    if (!ok) break;
    size += cobs.value();
    expected[size++] = 0;
    const auto written = tether::proxy::encode_frame(tether::ByteView(payload, length), tether::proxy::Integrity::crc16,
                                                     lead, tether::MutableByteView(framed));
    ok = written.ok() && written.value() == size;
    for (size_t i = 0; ok && i < size; ++i) ok = framed[i] == expected[i];
  }
  report("frame_encoder", ok);
}

// Start values whose carry stops in each byte in turn (and crosses the sign bit); the last wraps to 0 and
// must not carry past the counter.
void check_interrupt_counter() {
  static const uint32_t kStarts[] = {0u, 0xFEu, 0xFFu, 0xFFFFu, 0x1FFFFFFu, 0xFFFFFFu, 0x7FFFFFFFu, 0xFFFFFFFFu};
  bool ok = true;
  for (const uint32_t start : kStarts) {
    struct {
      volatile uint8_t before;
      volatile uint32_t counter;
      volatile uint8_t after;
    } guarded = {0x5A, start, 0xA5};
    tether::add_one_in_interrupt(guarded.counter);
    ok = ok && guarded.counter == start + 1u && guarded.before == 0x5A && guarded.after == 0xA5;
  }
  report("interrupt_counter", ok);
}

}  // namespace

int main() {
  uart_init();
  const uint32_t seed = eeprom_read_dword(reinterpret_cast<const uint32_t*>(0));
  put("selftest begin seed ");
  put_hex(seed, 8);
  put("\n");
  check_crc_values();
  checksum_random_buffers(seed);
  check_duplicate_filter();
  check_watchdog();
  check_partial_frame();
  check_request_ids();
  check_proxy_runs(seed);
  check_interrupt_counter();
  check_frame_encoder(seed);
  check_romi_runs(seed);
  check_elcano_runs(seed);
  check_elcano_required_fields(seed);
  put("selftest end failures ");
  put_hex(failures, 2);
  put("\n");
  while ((UCSR0A & _BV(TXC0)) == 0) {
  }
  cli();
  sleep_cpu();
  for (;;) {
  }
}
