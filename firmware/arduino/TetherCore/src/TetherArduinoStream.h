/// @file TetherArduinoStream.h
/// Runs of bytes from and to an Arduino `Stream`, for the libraries' glue: the device code takes its input
/// in runs (a decoder's tight loop over a span) and writes a frame at a time, as the bare-metal images do
/// with Tether's UART. Part of TetherCore, the one library every other Tether library uses.
///
/// Two kinds of port:
///   - the core's `HardwareSerial` (`Serial`, `Serial1`..): its receive and transmit rings are reached the
///     way the class offers them to derived classes (its protected members, through `SerialRings`), so a
///     run is read with one look at the ring's indices and a copy (or in place: `rx_run` / `rx_consume`),
///     and written with one index update and one interrupt enable, under the core's own rules (the same
///     idle-UART shortcut, TXC handling and interrupt-safe publication as its write()). The core's
///     read() and write() cost 27 and ~80 cycles a byte, called; these loops a few. A core whose
///     HardwareSerial lacks the AVR core's rings (SERIAL_RX_BUFFER_SIZE / SERIAL_TX_BUFFER_SIZE up to 256,
///     the UART0 bit names) gets the core's own functions called without virtual dispatch instead;
///   - any other `Stream` (SoftwareSerial, a USB CDC port, a sketch's own class): one virtual available()
///     per run, then a virtual read() per byte (all a `Stream` offers).
/// A core port passed as a plain `Stream&` (`Stream& port = Serial;`) is recognised (`core_serial`) and
/// takes the first path.
#pragma once

#include <Arduino.h>
#include <stdint.h>
#include <string.h>
#include <util/atomic.h>

#if defined(ARDUINO_ARCH_AVR) && defined(SERIAL_RX_BUFFER_SIZE) && defined(SERIAL_TX_BUFFER_SIZE) && \
    SERIAL_RX_BUFFER_SIZE <= 256 && SERIAL_TX_BUFFER_SIZE <= 256 && defined(UDRE0) && defined(TXC0) && \
    defined(U2X0) && defined(UDRIE0)
#define TETHER_ARDUINO_SERIAL_RINGS 1
#else
#define TETHER_ARDUINO_SERIAL_RINGS 0
#endif

namespace tether {
namespace arduino {

/// The core's hardware port (`Serial`, `Serial1`..) that `stream` is, or null (any other `Stream`, or
/// null): what a library's constructor taking a `Stream&` asks, so a port passed as a plain `Stream&`
/// still gets the rings. Compares addresses with the ports, which TetherArduinoPorts.cpp references
/// weakly: a sketch that uses no hardware port links none of them for this.
HardwareSerial* core_serial(Stream* stream);

// Small helpers on the hot paths are forced inline: -Os (what the Arduino IDE compiles with) would call
// them, and a call's register saves cost more than their bodies.
#define TETHER_ARDUINO_INLINE inline __attribute__((always_inline))

#if TETHER_ARDUINO_SERIAL_RINGS
/// The AVR core's HardwareSerial state, reached through its protected members (a derived class may name
/// them; the pointers to members apply to any HardwareSerial). Never constructed.
class SerialRings : public HardwareSerial {
 public:
  static unsigned char* rx_buffer(HardwareSerial& s) { return s.*(&SerialRings::_rx_buffer); }
  static volatile rx_buffer_index_t& rx_head(HardwareSerial& s) { return s.*(&SerialRings::_rx_buffer_head); }
  static volatile rx_buffer_index_t& rx_tail(HardwareSerial& s) { return s.*(&SerialRings::_rx_buffer_tail); }
  static unsigned char* tx_buffer(HardwareSerial& s) { return s.*(&SerialRings::_tx_buffer); }
  static volatile tx_buffer_index_t& tx_head(HardwareSerial& s) { return s.*(&SerialRings::_tx_buffer_head); }
  static volatile tx_buffer_index_t& tx_tail(HardwareSerial& s) { return s.*(&SerialRings::_tx_buffer_tail); }
  static volatile uint8_t* ucsra(HardwareSerial& s) { return s.*(&SerialRings::_ucsra); }
  static volatile uint8_t* ucsrb(HardwareSerial& s) { return s.*(&SerialRings::_ucsrb); }
  static volatile uint8_t* udr(HardwareSerial& s) { return s.*(&SerialRings::_udr); }
  static bool& written(HardwareSerial& s) { return s.*(&SerialRings::_written); }
};

/// Copies `count` bytes, at least one (a byte loop, no call: 7 cycles a byte on the AVR). On the AVR in
/// the X and Z pointers, which a function may use without saving them: the compiler's own loop took Y
/// (saved and restored: 8 cycles a call) as soon as a function had two copies.
TETHER_ARDUINO_INLINE void copy_bytes(uint8_t* to, const uint8_t* from, uint8_t count) {
#if defined(__AVR__)
  __asm__ volatile(
      "1: ld __tmp_reg__, X+\n\t"
      "st Z+, __tmp_reg__\n\t"
      "dec %[count]\n\t"
      "brne 1b"
      : [from] "+x"(from), [to] "+z"(to), [count] "+r"(count)
      :
      : "memory");
#else
  do {
    *to++ = *from++;
  } while (--count != 0);
#endif
}

/// True when `serial`'s receive ring holds a byte: one comparison of its indices.
TETHER_ARDUINO_INLINE bool rx_waiting(HardwareSerial& serial) { return SerialRings::rx_head(serial) != SerialRings::rx_tail(serial); }

/// The oldest bytes waiting in `serial`'s receive ring that lie one after the other in memory (up to the
/// newest or the ring's end): sets `data` to the first and returns how many (0: none). They stay in the
/// ring (its interrupt only adds after them) until `rx_consume`.
TETHER_ARDUINO_INLINE uint8_t rx_run(HardwareSerial& serial, const uint8_t*& data) {
  const uint8_t tail = SerialRings::rx_tail(serial);
  const uint8_t head = SerialRings::rx_head(serial);  // one read of the interrupt's index
  data = SerialRings::rx_buffer(serial) + tail;
  return static_cast<uint8_t>(head >= tail ? head - tail : SERIAL_RX_BUFFER_SIZE - tail);
}

/// Frees the `count` oldest bytes of `serial`'s receive ring (at most what `rx_run` returned).
TETHER_ARDUINO_INLINE void rx_consume(HardwareSerial& serial, uint8_t count) {
  unsigned int tail = static_cast<unsigned int>(SerialRings::rx_tail(serial)) + count;
  if (tail >= SERIAL_RX_BUFFER_SIZE) tail -= SERIAL_RX_BUFFER_SIZE;
  SerialRings::rx_tail(serial) = static_cast<rx_buffer_index_t>(tail);  // one store: the interrupt's room
}

/// Copies up to `capacity` waiting bytes out of `serial`'s receive ring; returns how many. At most two
/// stretches (to the ring's end, then from its start), each a plain byte copy; one tail store frees them
/// for the interrupt. Inline: for a caller that is itself out of line (`read_run_all`); others call
/// `read_ring`.
TETHER_ARDUINO_INLINE uint8_t take_ring(HardwareSerial& serial, uint8_t* bytes, uint8_t capacity) {
  const unsigned char* const ring = SerialRings::rx_buffer(serial);
  const uint8_t head = SerialRings::rx_head(serial);  // one read of the interrupt's index
  uint8_t tail = SerialRings::rx_tail(serial);
  if (capacity == 0) return 0;
  uint8_t count = 0;
  if (head < tail) {  // wrapped: the stretch up to the ring's end first
    const uint8_t last = static_cast<uint8_t>(SERIAL_RX_BUFFER_SIZE - 1 - tail);  // slots after tail's
    if (last >= capacity) {  // the bytes wanted end before the ring's end
      copy_bytes(bytes, ring + tail, capacity);
      SerialRings::rx_tail(serial) = static_cast<rx_buffer_index_t>(tail + capacity);
      return capacity;
    }
    count = static_cast<uint8_t>(last + 1u);
    copy_bytes(bytes, ring + tail, count);
    tail = 0;
  }
  const uint8_t room = static_cast<uint8_t>(capacity - count);
  if (room != 0 && head != tail) {
    const uint8_t waiting = static_cast<uint8_t>(head - tail);  // head > tail here
    const uint8_t run = waiting < room ? waiting : room;
    copy_bytes(bytes + count, ring + tail, run);
    count = static_cast<uint8_t>(count + run);
    tail = static_cast<uint8_t>(tail + run);
  }
  SerialRings::rx_tail(serial) = static_cast<rx_buffer_index_t>(tail);  // one store: the interrupt's room
  return count;
}

/// `take_ring` out of line: its callers' empty polls (`rx_waiting`) pay for none of its registers.
__attribute__((noinline)) inline uint8_t read_ring(HardwareSerial& serial, uint8_t* bytes, uint8_t capacity) {
  return take_ring(serial, bytes, capacity);
}

/// Takes up to `capacity` bytes waiting in `serial`'s receive ring into `bytes`; returns how many. A lone
/// byte, what a sketch's loop mostly finds (it comes round faster than the line delivers), is taken inline.
TETHER_ARDUINO_INLINE uint8_t read_run(HardwareSerial& serial, uint8_t* bytes, uint8_t capacity) {
  const uint8_t tail = SerialRings::rx_tail(serial);
  const uint8_t head = SerialRings::rx_head(serial);  // one read of the interrupt's index
  if (head == tail) return 0;
  const uint8_t next = static_cast<uint8_t>(tail + 1u == SERIAL_RX_BUFFER_SIZE ? 0u : tail + 1u);
  if (next != head) return read_ring(serial, bytes, capacity);
  bytes[0] = SerialRings::rx_buffer(serial)[tail];
  SerialRings::rx_tail(serial) = next;  // one store: the interrupt's room
  return 1;
}

/// Writes `byte` straight into `serial`'s data register when the UART is idle and nothing is queued (the
/// core's shortcut, in its order: the data register first, then TXC cleared, together); false otherwise.
/// Once a byte is queued, the interrupt sends the rest: the ring never empties while bytes wait.
TETHER_ARDUINO_INLINE bool write_idle(HardwareSerial& serial, uint8_t byte) {
  volatile uint8_t* const ucsra = SerialRings::ucsra(serial);
  if (SerialRings::tx_head(serial) != SerialRings::tx_tail(serial) || (*ucsra & _BV(UDRE0)) == 0) return false;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    *SerialRings::udr(serial) = byte;
#ifdef MPCM0
    *ucsra = static_cast<uint8_t>((*ucsra & (_BV(U2X0) | _BV(MPCM0))) | _BV(TXC0));
#else
    *ucsra = static_cast<uint8_t>(*ucsra & (_BV(U2X0) | _BV(TXC0)));
#endif
  }
  return true;
}

/// Hands the bytes [bytes, end) to the core's write() one by one: it waits while the transmit ring is
/// full (or, with interrupts off, polls the UART itself). Out of line: the ring's fast path below makes no
/// call, so it keeps its values in the registers a call may clobber and saves none.
__attribute__((noinline)) inline void write_waiting(HardwareSerial& serial, const uint8_t* bytes, const uint8_t* end) {
  do {
    serial.HardwareSerial::write(*bytes++);
  } while (bytes != end);
}

/// Publishes `head` as the transmit ring's new head together with the interrupt's enable, in one atomic
/// step (the core's rule: the head never without the enable).
TETHER_ARDUINO_INLINE void tx_publish(HardwareSerial& serial, uint8_t head) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    SerialRings::tx_head(serial) = head;
    *SerialRings::ucsrb(serial) = static_cast<uint8_t>(*SerialRings::ucsrb(serial) | _BV(UDRIE0));
  }
}

/// Queues the bytes [bytes, end) on `serial`'s transmit ring: as many as it has room for in one pass (at
/// most two stretches: to the ring's end, then from its start), whose head is then published with the
/// interrupt's enable (`tx_publish`); what finds the ring full goes through `write_waiting`. Inline: for a
/// caller out of line itself (`write_all_inline`); others call `write_ring`.
TETHER_ARDUINO_INLINE void put_ring(HardwareSerial& serial, const uint8_t* bytes, const uint8_t* end) {
  const uint8_t tail = SerialRings::tx_tail(serial);  // the interrupt may free more meanwhile: not counted
  const uint8_t head = SerialRings::tx_head(serial);
  uint8_t room = static_cast<uint8_t>(static_cast<unsigned int>(tail) - head - 1u);  // one slot stays free
  if (SERIAL_TX_BUFFER_SIZE != 256 && tail <= head) room = static_cast<uint8_t>(room + SERIAL_TX_BUFFER_SIZE);
  if (room != 0) {
    const uint16_t left = static_cast<uint16_t>(end - bytes);
    uint8_t count = left < room ? static_cast<uint8_t>(left) : room;
    unsigned char* const ring = SerialRings::tx_buffer(serial);
    uint8_t* to = ring + head;
    const uint8_t last = static_cast<uint8_t>(SERIAL_TX_BUFFER_SIZE - 1 - head);  // slots after head's
    uint8_t next;
    if (count <= last) {
      next = static_cast<uint8_t>(head + count);
    } else {  // to the ring's end, then from its start
      const uint8_t first = static_cast<uint8_t>(last + 1u);
      copy_bytes(to, bytes, first);
      bytes += first;
      to = ring;
      count = static_cast<uint8_t>(count - first);
      next = count;
    }
    if (count != 0) {
      copy_bytes(to, bytes, count);
      bytes += count;
    }
    tx_publish(serial, next);
  }
  if (bytes != end) write_waiting(serial, bytes, end);
}

/// `put_ring` out of line.
__attribute__((noinline)) inline void write_ring(HardwareSerial& serial, const uint8_t* bytes, const uint8_t* end) {
  put_ring(serial, bytes, end);
}

/// Queues `byte` on `serial`'s transmit ring (`write_waiting` when it is full).
__attribute__((noinline)) inline void write_queued(HardwareSerial& serial, uint8_t byte) {
  const uint8_t head = SerialRings::tx_head(serial);
  const uint8_t next = static_cast<uint8_t>(head + 1u == SERIAL_TX_BUFFER_SIZE ? 0u : head + 1u);
  if (next == SerialRings::tx_tail(serial)) {
    serial.HardwareSerial::write(byte);
    return;
  }
  SerialRings::tx_buffer(serial)[head] = byte;
  tx_publish(serial, next);
}

/// Sends `byte` on `serial` as its write() would: straight into the idle UART (a reply's first byte, the
/// turnaround) or queued.
TETHER_ARDUINO_INLINE void write_byte(HardwareSerial& serial, uint8_t byte) {
  SerialRings::written(serial) = true;  // what flush() checks
  if (!write_idle(serial, byte)) write_queued(serial, byte);
}

/// Queues `size` bytes on `serial` as its write() would each (see `write_idle`, `write_ring`).
TETHER_ARDUINO_INLINE void write_all(HardwareSerial& serial, const uint8_t* bytes, size_t size) {
  SerialRings::written(serial) = true;  // what flush() checks
  const uint8_t* const end = bytes + size;
  while (bytes != end && write_idle(serial, *bytes)) ++bytes;  // as long as the UART takes them at once
  if (bytes != end) write_ring(serial, bytes, end);
}
/// `write_all` for a caller that is out of line itself (a stream's write_all): a run the ring has room for
/// is copied inline (in at most two stretches); one that must wait for room goes to `write_ring`, called
/// last, so that the caller saves no registers for it (`put_ring` inline, with its call to
/// `write_waiting` in the middle, made it save six: 24 cycles a reply).
TETHER_ARDUINO_INLINE void write_all_inline(HardwareSerial& serial, const uint8_t* bytes, size_t size) {
  SerialRings::written(serial) = true;  // what flush() checks
  const uint8_t* const end = bytes + size;
  while (bytes != end && write_idle(serial, *bytes)) ++bytes;  // as long as the UART takes them at once
  if (bytes == end) return;
  const uint8_t head = SerialRings::tx_head(serial);
  const uint8_t tail = SerialRings::tx_tail(serial);  // the interrupt may free more meanwhile: not counted
  uint8_t room = static_cast<uint8_t>(static_cast<unsigned int>(tail) - head - 1u);  // one slot stays free
  if (SERIAL_TX_BUFFER_SIZE != 256 && tail <= head) room = static_cast<uint8_t>(room + SERIAL_TX_BUFFER_SIZE);
  const uint8_t count = static_cast<uint8_t>(end - bytes);  // a stream's write_all: at most 255
  if (count <= room) {
    unsigned char* const ring = SerialRings::tx_buffer(serial);
    const uint8_t first = static_cast<uint8_t>(SERIAL_TX_BUFFER_SIZE - head);  // slots up to the ring's end
    if (count < first) {
      copy_bytes(ring + head, bytes, count);
      tx_publish(serial, static_cast<uint8_t>(head + count));
    } else {  // to the ring's end, then from its start
      copy_bytes(ring + head, bytes, first);
      const uint8_t rest = static_cast<uint8_t>(count - first);
      if (rest != 0) copy_bytes(ring, bytes + first, rest);
      tx_publish(serial, rest);
    }
    return;
  }
  write_ring(serial, bytes, end);
}
#else
/// Takes up to `capacity` bytes waiting in `serial`'s receive ring into `bytes`; returns how many.
inline uint8_t read_run(HardwareSerial& serial, uint8_t* bytes, uint8_t capacity) {
  const int waiting = serial.HardwareSerial::available();
  const uint8_t count = waiting < static_cast<int>(capacity) ? static_cast<uint8_t>(waiting) : capacity;
  // available() counted them and nothing else reads this ring (its interrupt only adds): each read()
  // delivers one.
  for (uint8_t i = 0; i != count; ++i) bytes[i] = static_cast<uint8_t>(serial.HardwareSerial::read());
  return count;
}

/// Queues `size` bytes on `serial` (waiting while its TX ring is full), each through the core's own
/// write(uint8_t) without virtual dispatch.
inline void write_all(HardwareSerial& serial, const uint8_t* bytes, size_t size) {
  for (size_t i = 0; i != size; ++i) serial.HardwareSerial::write(bytes[i]);
}

/// Sends `byte` on `serial` through the core's own write(uint8_t).
inline void write_byte(HardwareSerial& serial, uint8_t byte) { serial.HardwareSerial::write(byte); }

/// `write_all`.
inline void write_all_inline(HardwareSerial& serial, const uint8_t* bytes, size_t size) { write_all(serial, bytes, size); }
#endif

/// Takes up to `capacity` bytes waiting in `stream` into `bytes`; returns how many (a read() that finds
/// nothing ends the run early). Out of line: it keeps its registers off the HardwareSerial path. One
/// available() per run; the stream's read() is looked up once per run too (GCC's bound member function
/// extension: the virtual call's target as a plain function pointer), so each byte costs the call itself,
/// not the two table loads before it, and the loop runs on a write pointer, not an index.
__attribute__((noinline)) inline uint8_t read_run(Stream& stream, uint8_t* bytes, uint8_t capacity) {
  const int waiting = stream.available();
  if (waiting <= 0 || capacity == 0) return 0;
  const uint8_t count = waiting < static_cast<int>(capacity) ? static_cast<uint8_t>(waiting) : capacity;
  uint8_t* to = bytes;
  uint8_t* const end = bytes + count;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpmf-conversions"
  typedef int (*ReadFunction)(Stream*);
  const ReadFunction read = reinterpret_cast<ReadFunction>(stream.*(&Stream::read));
#pragma GCC diagnostic pop
  do {
    const int byte = read(&stream);
    if (byte < 0) break;
#if defined(__AVR__)
    // A post-increment store: the compiler's own kept the pointer one ahead and stepped it back (5
    // cycles a byte more).
    __asm__ volatile("st %a[to]+, %[byte]" : [to] "+e"(to) : [byte] "r"(static_cast<uint8_t>(byte)) : "memory");
#else
    *to++ = static_cast<uint8_t>(byte);
#endif
  } while (to != end);
#else
  do {
    const int byte = stream.read();
    if (byte < 0) break;
    *to++ = static_cast<uint8_t>(byte);
  } while (to != end);
#endif
  return static_cast<uint8_t>(to - bytes);
}

/// Reads a run from `hardware` when it is set (the fast path), else from `stream`.
TETHER_ARDUINO_INLINE uint8_t read_run(HardwareSerial* hardware, Stream& stream, uint8_t* bytes, uint8_t capacity) {
  return hardware != nullptr ? read_run(*hardware, bytes, capacity) : read_run(stream, bytes, capacity);
}

/// `read_run` for a caller that is out of line itself (a stream's read_some): the ring's copy inline in it.
TETHER_ARDUINO_INLINE uint8_t read_run_inline(HardwareSerial* hardware, Stream& stream, uint8_t* bytes, uint8_t capacity) {
#if TETHER_ARDUINO_SERIAL_RINGS
  if (hardware == nullptr) return read_run(stream, bytes, capacity);
  if (!rx_waiting(*hardware)) return 0;
  return take_ring(*hardware, bytes, capacity);
#else
  return read_run(hardware, stream, bytes, capacity);
#endif
}

/// Writes `size` bytes to `stream` (Print's write(buffer, size)). Out of line, as `read_run(Stream&)`.
__attribute__((noinline)) inline void write_all(Print& stream, const uint8_t* bytes, size_t size) {
  stream.write(bytes, size);
}

/// Writes `size` bytes to `hardware` when it is set, else to `stream`.
TETHER_ARDUINO_INLINE void write_all(HardwareSerial* hardware, Print& stream, const uint8_t* bytes, size_t size) {
  if (hardware != nullptr) {
    write_all(*hardware, bytes, size);
  } else {
    write_all(stream, bytes, size);
  }
}

}  // namespace arduino
}  // namespace tether
