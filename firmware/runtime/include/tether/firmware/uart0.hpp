/// @file uart0.hpp
/// Interrupt-driven UART0 (the Uno's USB serial, pins 0/1) with compile-time RX and TX ring sizes.
///
/// `Uart0<RxSize, TxSize>` is a class of static functions: there is one UART0, so there is one set of
/// buffers, and the interrupt handlers reach them without a pointer. Exactly one translation unit of an
/// image names the chosen type in `TETHER_UART0_ISRS`, which defines the two handlers for it:
///
///     using Serial = tether::firmware::Uart0<128, 64>;   // RX ring 128 bytes, TX ring 64 bytes
///     TETHER_UART0_ISRS(Serial);                         // at global scope, in one .cpp
///     ...
///     Serial::begin(115200);  sei();                      // or runtime_init<Serial>(115200)
///
/// A second `TETHER_UART0_ISRS` fails to link (duplicate `__vector_18`/`__vector_19`); a missing one, or
/// one naming another `Uart0` type than the code uses, fails to link with an undefined reference to
/// `Uart0<...>::interrupts_defined_by_TETHER_UART0_ISRS` -- instead of an image that resets through
/// `__bad_interrupt` on the first received byte.
///
/// Receiving never blocks and never drops silently: a byte that finds the RX ring full is discarded and
/// counted in `UartCounters::rx_overflows`; framing and hardware overrun errors are counted too.
/// Sending blocks only in `write()`, and only while the TX ring is full: with interrupts enabled it
/// sleeps until the UDRE interrupt frees a slot; with interrupts disabled (inside an ISR or an
/// ATOMIC_BLOCK) it transmits by polling instead of deadlocking.
///
/// Frame format is 8N1. The runtime owns SMCR (the sleep mode): `write()` and `idle()` sleep in IDLE.
#pragma once

#include <avr/interrupt.h>
#include <avr/io.h>
#include <stddef.h>
#include <stdint.h>
#include <util/atomic.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/firmware/byte_ring.hpp"
#include "tether/firmware/power.hpp"

namespace tether {
namespace firmware {

/// Error counters of UART0. They only grow (wrap at 2^32). Plain data: a snapshot.
struct UartCounters {
  uint32_t rx_overflows = 0;    ///< Received bytes discarded because the RX ring was full.
  uint32_t framing_errors = 0;  ///< Bytes received with FE0 set (bad stop bit: wrong baud, noise, break).
  uint32_t data_overruns = 0;   ///< DOR0 events: the hardware lost bytes because the RX interrupt was late.
};

/// Baud-rate register values for one rate.
struct UartBaudSetting {
  uint16_t ubrr;      ///< UBRR0 (12 bits).
  bool double_speed;  ///< U2X0: divide by 8 instead of 16.
};

/// round(f_cpu / (divisor * baud)) - 1, clamped to UBRR0's 12 bits.
constexpr uint16_t uart_ubrr_for(uint32_t f_cpu, uint32_t baud, uint8_t divisor) {
  const uint32_t per_bit = static_cast<uint32_t>(divisor) * (baud == 0 ? 1u : baud);
  uint32_t quotient = (f_cpu + per_bit / 2u) / per_bit;
  if (quotient == 0) quotient = 1;
  if (quotient > 4096u) quotient = 4096u;
  return static_cast<uint16_t>(quotient - 1u);
}

/// |actual rate - baud| in bit/s for a UBRR value and divisor (16, or 8 with U2X0).
constexpr uint32_t uart_baud_error(uint32_t f_cpu, uint32_t baud, uint8_t divisor, uint16_t ubrr) {
  const uint32_t actual = f_cpu / (static_cast<uint32_t>(divisor) * (static_cast<uint32_t>(ubrr) + 1u));
  return actual > baud ? actual - baud : baud - actual;
}

/// UBRR0/U2X0 for `baud` at `f_cpu`, chosen like the Arduino core: the mode with the lower rate error,
/// normal speed on a tie (16 samples per bit tolerate more noise than 8). Exception, as in the Arduino
/// core: 57600 at 16 MHz uses normal speed, because the Uno's USB bridge (16U2) does so at that rate and
/// matching its divisor gives both ends the same +2.1% error. 115200 at 16 MHz gives U2X0=1, UBRR0=16.
constexpr UartBaudSetting uart_baud_setting(uint32_t f_cpu, uint32_t baud) {
  const uint16_t normal = uart_ubrr_for(f_cpu, baud, 16);
  const uint16_t doubled = uart_ubrr_for(f_cpu, baud, 8);
  if (f_cpu == 16000000u && baud == 57600u) return UartBaudSetting{normal, false};
  return uart_baud_error(f_cpu, baud, 8, doubled) < uart_baud_error(f_cpu, baud, 16, normal)
             ? UartBaudSetting{doubled, true}
             : UartBaudSetting{normal, false};
}

/// UART0 with an RX ring of `RxSize` and a TX ring of `TxSize` bytes (powers of two, 2..256; 256 holds
/// 255). All functions are static; see the file comment for `TETHER_UART0_ISRS`.
template <uint16_t RxSize = 64, uint16_t TxSize = 64>
class Uart0 {
 public:
  /// Bytes the RX ring holds before it starts discarding (and counting) received bytes.
  static constexpr uint8_t kRxCapacity = ByteRing<RxSize>::kCapacity;
  /// Bytes the TX ring holds before `write()` waits.
  static constexpr uint8_t kTxCapacity = ByteRing<TxSize>::kCapacity;

  /// Configures 8N1 at `baud` (see `uart_baud_setting`), empties both rings and enables the receiver,
  /// the transmitter and the RX interrupt. Does not enable interrupts globally (`sei()` is the
  /// caller's, or `runtime_init`'s). Bytes still queued for sending are discarded.
  static void begin(uint32_t baud) {
    // A volatile read so every image that calls begin() references the symbol TETHER_UART0_ISRS defines.
    static_cast<void>(*static_cast<const volatile uint8_t*>(&interrupts_defined_by_TETHER_UART0_ISRS));
    const UartBaudSetting setting = uart_baud_setting(F_CPU, baud);
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      UCSR0B = 0;
      rx_.head = 0;
      rx_.tail = 0;
      tx_.head = 0;
      tx_.tail = 0;
      written_ = false;
      ucsr0a_ = static_cast<uint8_t>(setting.double_speed ? _BV(U2X0) : 0);
      UCSR0A = ucsr0a_;
      UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
      UBRR0H = static_cast<uint8_t>(setting.ubrr >> 8);
      // UBRR0L after U2X0 and the frame format: simavr recomputes its byte time only on this write.
      UBRR0L = static_cast<uint8_t>(setting.ubrr);
      // Receiver on only now, so no byte is sampled at a stale rate.
      UCSR0B = _BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0);
    }
  }

  // --- receiving --------------------------------------------------------------------------------

  /// Bytes received and not yet read.
  static uint8_t available() { return rx_.used(); }

  /// Next received byte (0..255), or -1 when none is waiting.
  static int16_t read() {
    const uint8_t tail = rx_.tail;
    if (rx_.head == tail) return -1;
    compiler_barrier();  // read the slot only after seeing the head that published it
    const uint8_t byte = rx_.bytes[tail & ByteRing<RxSize>::kMask];
    compiler_barrier();  // and before the slot is handed back to the ISR
    rx_.tail = static_cast<uint8_t>(tail + 1u);
    return byte;
  }

  /// Copies up to `out.size()` received bytes into `out`; returns how many (0 when none is waiting).
  static size_t read(MutableByteView out) {
    const uint8_t head = rx_.head;
    uint8_t tail = rx_.tail;
    compiler_barrier();
    size_t count = 0;
    while (count < out.size() && tail != head) {
      out[count++] = rx_.bytes[tail & ByteRing<RxSize>::kMask];
      tail = static_cast<uint8_t>(tail + 1u);
    }
    compiler_barrier();
    rx_.tail = tail;
    return count;
  }

  /// The oldest received bytes that lie contiguously in the RX ring (up to its end; empty when none), to
  /// read in place: no copy. The ISR never writes into them until `consume` hands them back, so a reader
  /// that executes a frame in between keeps them out of the ring's free space meanwhile.
  static ByteView peek() {
    const uint8_t tail = rx_.tail;
    const uint8_t used = static_cast<uint8_t>(rx_.head - tail);
    compiler_barrier();  // read the slots only after seeing the head that published them
    const uint8_t offset = static_cast<uint8_t>(tail & ByteRing<RxSize>::kMask);
    const uint16_t to_end = static_cast<uint16_t>(RxSize - offset);
    return ByteView(&rx_.bytes[offset], used < to_end ? used : to_end);
  }
  /// Hands the first `count` bytes of the last `peek` back to the ring (count <= its size).
  static void consume(uint8_t count) {
    compiler_barrier();  // after the reads of the slots
    rx_.tail = static_cast<uint8_t>(rx_.tail + count);
  }

  // --- sending ----------------------------------------------------------------------------------

  /// Bytes `write()` can queue now without waiting.
  static uint8_t available_for_write() { return tx_.space(); }

  /// Queues `byte` if there is room; false (nothing queued) when the TX ring is full. Never waits.
  static bool try_write(uint8_t byte) {
    const uint8_t head = tx_.head;
    if (static_cast<uint8_t>(head - tx_.tail) == ByteRing<TxSize>::kCapacity) return false;
    tx_.bytes[head & ByteRing<TxSize>::kMask] = byte;
    compiler_barrier();  // the byte must be in its slot before the ISR can see the new head
    tx_.head = static_cast<uint8_t>(head + 1u);
    start_transmitter();
    return true;
  }

  /// Queues as many bytes of `bytes` as fit now; returns how many (a prefix). Never waits.
  static size_t try_write(ByteView bytes) {
    const uint8_t head = tx_.head;
    const uint8_t space = static_cast<uint8_t>(ByteRing<TxSize>::kCapacity - static_cast<uint8_t>(head - tx_.tail));
    const uint8_t count = bytes.size() < space ? static_cast<uint8_t>(bytes.size()) : space;
    if (count == 0) return 0;
    // In at most two runs (to the ring's end, then from its start): a pointer step per byte, no index
    // arithmetic.
    const uint8_t offset = static_cast<uint8_t>(head & ByteRing<TxSize>::kMask);
    const uint16_t to_end = static_cast<uint16_t>(TxSize - offset);
    const uint8_t first = count < to_end ? count : static_cast<uint8_t>(to_end);
    const uint8_t* in = copy_run(&tx_.bytes[offset], bytes.data(), first);
    if (first != count) copy_run(&tx_.bytes[0], in, static_cast<uint8_t>(count - first));
    compiler_barrier();  // the bytes must be in their slots before the ISR can see the new head
    tx_.head = static_cast<uint8_t>(head + count);
    start_transmitter();
    return count;
  }

  /// Queues `byte`, waiting while the TX ring is full (see the file comment: sleeps with interrupts
  /// enabled, polls the transmitter with interrupts disabled).
  static void write(uint8_t byte) {
    while (!try_write(byte)) wait_for_space();
  }

  /// As `write(byte)`, but when nothing is queued and the transmitter is idle (UDRIE0 off, UDR0 empty)
  /// the byte goes straight to UDR0, ~60 cycles sooner than through the ring and the UDRE interrupt:
  /// for the first byte of an answer (a Romi device's turnaround). Reads UCSR0A only when the ring is
  /// empty: simavr slows down (usleep) on UCSR0A reads made while RXC0 and TXC0 are both clear, which is
  /// rare here (after a pause TXC0 is set) but would be per byte in a writer of single bytes.
  static void write_now(uint8_t byte) {
    if (tx_.head == tx_.tail && (UCSR0B & _BV(UDRIE0)) == 0 && (UCSR0A & _BV(UDRE0)) != 0) {
      // UDRIE0 off: the UDRE interrupt cannot run, so nothing else touches UDR0 until this returns.
      UDR0 = byte;
      clear_tx_complete();
      written_ = true;
      return;
    }
    write(byte);
  }

  /// Queues every byte of `bytes`, waiting for room as `write(uint8_t)` does.
  static void write(ByteView bytes) {
    while (!bytes.empty()) {
      const size_t queued = try_write(bytes);
      bytes = bytes.subview(queued);
      if (!bytes.empty()) wait_for_space();
    }
  }

  /// Waits until every queued byte has left the pin (TXC0: last stop bit sent). Call before
  /// `system_reset()` or sleeping deeper than IDLE. Returns at once if nothing was ever written.
  /// Sleeps while the ring drains (UDRIE0 on: the UDRE interrupt wakes it), then spins on TXC0 for the
  /// last byte, which raises no interrupt. With interrupts disabled it moves the bytes by polling.
  static void flush() {
    if (!written_) return;
    while ((UCSR0B & _BV(UDRIE0)) != 0) {
      if (interrupts_enabled()) {
        idle_unless([] { return (UCSR0B & _BV(UDRIE0)) == 0; });
      } else if ((UCSR0A & _BV(UDRE0)) != 0) {
        on_udre_interrupt();
      }
    }
    while ((UCSR0A & _BV(TXC0)) == 0) {
    }
  }

  /// Snapshot of the error counters.
  static UartCounters counters() {
    UartCounters copy;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { copy = counters_; }
    return copy;
  }

  // --- interrupt side (called by the handlers TETHER_UART0_ISRS defines) ---------------------------

  /// USART_RX_vect's work in C++ (TETHER_UART0_ISRS's handler is rx_handler, the same in assembly): stores
  /// the received byte, or counts it lost when the RX ring is full. Always inlined, for a handler of an
  /// image's own: it then saves only the registers this code uses, not every call-clobbered one.
  __attribute__((always_inline)) static void on_rx_interrupt() {
    const uint8_t status = UCSR0A;  // FE0/DOR0 describe the byte in UDR0: read them first
    const uint8_t byte = UDR0;
    if ((status & _BV(FE0)) != 0) add_one_in_interrupt(counters_.framing_errors);
    if ((status & _BV(DOR0)) != 0) add_one_in_interrupt(counters_.data_overruns);
    const uint8_t head = rx_.head;
    if (static_cast<uint8_t>(head - rx_.tail) == ByteRing<RxSize>::kCapacity) {
      add_one_in_interrupt(counters_.rx_overflows);
      return;
    }
    rx_.bytes[head & ByteRing<RxSize>::kMask] = byte;
    rx_.head = static_cast<uint8_t>(head + 1u);
  }

  /// USART_RX_vect itself (TETHER_UART0_ISRS's, naked): on_rx_interrupt in assembly, saving only the four
  /// registers and SREG it uses (the compiler's handler saved nine): ~50 cycles a byte received against
  /// ~72. The error counters (a framing error, an overrun, a full ring: rare) are counted by a subroutine
  /// of the handler. Only inside a naked handler: it ends in RETI.
  __attribute__((always_inline)) static void rx_handler() {
    __asm__ __volatile__(
        "push r30\n\t"
        "in r30, %[sreg]\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "lds r24, %[ucsra]\n\t"  // FE0/DOR0 describe the byte in UDR0: read them first
        "lds r25, %[udr]\n\t"
        "andi r24, %[errors]\n\t"
        "brne 5f\n\t"
        "1:\n\t"
        "lds r24, %[head]\n\t"
        "lds r30, %[tail]\n\t"
        "mov r31, r24\n\t"
        "sub r31, r30\n\t"
        "cpi r31, %[capacity]\n\t"
        "breq 6f\n\t"
        "mov r30, r24\n\t"
        "andi r30, %[mask]\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[bytes]))\n\t"
        "sbci r31, hi8(-(%[bytes]))\n\t"
        "st Z, r25\n\t"
        "subi r24, 0xFF\n\t"  // head + 1
        "sts %[head], r24\n\t"
        "2:\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "out %[sreg], r30\n\t"
        "pop r30\n\t"
        "reti\n\t"
        "5:\n\t"  // a framing error and/or an overrun
        "sbrs r24, %[fe]\n\t"
        "rjmp 7f\n\t"
        "ldi r30, lo8(%[framing])\n\t"
        "ldi r31, hi8(%[framing])\n\t"
        "rcall 8f\n\t"
        "7:\n\t"
        "sbrs r24, %[dor]\n\t"
        "rjmp 1b\n\t"
        "ldi r30, lo8(%[overruns])\n\t"
        "ldi r31, hi8(%[overruns])\n\t"
        "rcall 8f\n\t"
        "rjmp 1b\n\t"
        "6:\n\t"  // the ring is full: the byte is dropped, counted
        "ldi r30, lo8(%[overflows])\n\t"
        "ldi r31, hi8(%[overflows])\n\t"
        "rcall 8f\n\t"
        "rjmp 2b\n\t"
        "8:\n\t"  // +1 on the 32-bit counter at Z, the carry through its bytes (add_one_in_interrupt)
        "push r24\n\t"
        "ld r24, Z\n\tinc r24\n\tst Z+, r24\n\tbrne 9f\n\t"
        "ld r24, Z\n\tinc r24\n\tst Z+, r24\n\tbrne 9f\n\t"
        "ld r24, Z\n\tinc r24\n\tst Z+, r24\n\tbrne 9f\n\t"
        "ld r24, Z\n\tinc r24\n\tst Z, r24\n\t"
        "9:\n\t"
        "pop r24\n\t"
        "ret"
        :
        : [sreg] "I"(_SFR_IO_ADDR(SREG)), [ucsra] "n"(_SFR_MEM_ADDR(UCSR0A)), [udr] "n"(_SFR_MEM_ADDR(UDR0)),
          [errors] "M"(_BV(FE0) | _BV(DOR0)), [fe] "I"(FE0), [dor] "I"(DOR0), [head] "i"(&rx_.head),
          [tail] "i"(&rx_.tail), [bytes] "i"(&rx_.bytes[0]), [mask] "M"(static_cast<int>(ByteRing<RxSize>::kMask)),
          [capacity] "M"(static_cast<int>(ByteRing<RxSize>::kCapacity)), [framing] "i"(&counters_.framing_errors),
          [overruns] "i"(&counters_.data_overruns), [overflows] "i"(&counters_.rx_overflows)
        : "memory");
  }

  /// USART_UDRE_vect's work, for the polling paths (interrupts disabled): moves the next queued byte to
  /// UDR0; disables the interrupt when the ring is empty. TXC0 is cleared with the last byte only: flush()
  /// looks at it once the ring is empty, and a byte written while UDR0's previous one still shifts out
  /// keeps it clear anyway (TXC0 needs an empty UDR0).
  __attribute__((always_inline)) static void on_udre_interrupt() {
    const uint8_t tail = tx_.tail;
    if (tx_.head != tail) {
      UDR0 = tx_.bytes[tail & ByteRing<TxSize>::kMask];
      tx_.tail = static_cast<uint8_t>(tail + 1u);
      if (tx_.head != tx_.tail) return;
      clear_tx_complete();
    }
    UCSR0B = static_cast<uint8_t>(UCSR0B & ~_BV(UDRIE0));
  }

  /// USART_UDRE_vect itself (TETHER_UART0_ISRS's, naked): on_udre_interrupt in assembly, saving only the
  /// three registers and SREG it uses. The compiler's handler saved seven (r0, r1, r24, r25, r30, r31 and
  /// SREG) and reloaded the ring's counters: 65 cycles a byte sent against 45 here, a third of the
  /// interrupt time of a stream of frames. Only inside a naked handler: it ends in RETI.
  __attribute__((always_inline)) static void udre_handler() {
    __asm__ __volatile__(
        "push r30\n\t"
        "in r30, %[sreg]\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "push r24\n\t"
        "lds r24, %[tail]\n\t"
        "lds r30, %[head]\n\t"
        "cp r24, r30\n\t"
        "breq 2f\n\t"         // empty (start_transmitter re-enabled it after the ring drained): off
        "mov r30, r24\n\t"
        "andi r30, %[mask]\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[bytes]))\n\t"
        "sbci r31, hi8(-(%[bytes]))\n\t"
        "ld r30, Z\n\t"
        "sts %[udr], r30\n\t"
        "subi r24, 0xFF\n\t"  // tail + 1
        "sts %[tail], r24\n\t"
        "lds r30, %[head]\n\t"
        "cp r24, r30\n\t"
        "brne 3f\n\t"
        "lds r30, %[ucsr0a]\n\t"  // the last byte: clear TXC0 (clear_tx_complete)
        "ori r30, %[txc]\n\t"
        "sts %[ucsra], r30\n\t"
        "2:\n\t"
        "lds r30, %[ucsrb]\n\t"
        "andi r30, %[udrie_off]\n\t"
        "sts %[ucsrb], r30\n\t"
        "3:\n\t"
        "pop r24\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "out %[sreg], r30\n\t"
        "pop r30\n\t"
        "reti"
        :
        : [sreg] "I"(_SFR_IO_ADDR(SREG)), [tail] "i"(&tx_.tail), [head] "i"(&tx_.head), [bytes] "i"(&tx_.bytes[0]),
          [mask] "M"(static_cast<int>(ByteRing<TxSize>::kMask)), [udr] "n"(_SFR_MEM_ADDR(UDR0)), [ucsr0a] "i"(&ucsr0a_),
          [txc] "M"(_BV(TXC0)), [ucsra] "n"(_SFR_MEM_ADDR(UCSR0A)), [ucsrb] "n"(_SFR_MEM_ADDR(UCSR0B)),
          [udrie_off] "M"(0xFF & ~_BV(UDRIE0))
        : "memory");
  }

  /// Declared here, defined (for this exact type) only by TETHER_UART0_ISRS: see the file comment.
  static const uint8_t interrupts_defined_by_TETHER_UART0_ISRS;

 private:
  static bool interrupts_enabled() { return (SREG & _BV(SREG_I)) != 0; }

  /// Copies `count` (> 0) bytes from `in` to `out`; returns where `in` ended.
  static const uint8_t* copy_run(uint8_t* out, const uint8_t* in, uint8_t count) {
    do {
      *out++ = *in++;
    } while (--count != 0);
    return in;
  }

  /// Writing 1 clears TXC0, so flush() waits for this byte. Written from the value begin() chose
  /// rather than read-modify-write: U2X0 keeps its value, FE0/DOR0/UPE0 must be written 0 anyway, and
  /// simavr calls usleep() on every UCSR0A read made while RXC0 and TXC0 are both clear (it assumes a
  /// polling loop), which made a bulk echo 8x slower in wall time when done here per byte.
  static void clear_tx_complete() { UCSR0A = static_cast<uint8_t>(ucsr0a_ | _BV(TXC0)); }

  /// Enables the UDRE interrupt after bytes were queued. UCSR0B is outside SBI/CBI range, so the
  /// read-modify-write must not interleave with the ISR clearing UDRIE0.
  static void start_transmitter() {
    written_ = true;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { UCSR0B = static_cast<uint8_t>(UCSR0B | _BV(UDRIE0)); }
  }

  /// Returns once the TX ring may have room. Interrupts enabled: sleeps in IDLE unless room appeared
  /// (the ring is not empty, so UDRIE0 is on and the UDRE interrupt will wake the CPU). Interrupts
  /// disabled: no interrupt can come, so it moves one byte itself when UDR0 is free.
  static void wait_for_space() {
    if (!interrupts_enabled()) {
      if ((UCSR0A & _BV(UDRE0)) != 0) on_udre_interrupt();
      return;
    }
    idle_unless([] { return !tx_.full(); });
  }

  static ByteRing<RxSize> rx_;
  static ByteRing<TxSize> tx_;
  static UartCounters counters_;
  static bool written_;    // main loop only: something was sent since begin(), so TXC will come
  static uint8_t ucsr0a_;  // UCSR0A's configuration bits (U2X0) as begin() set them
};

template <uint16_t RxSize, uint16_t TxSize>
constexpr uint8_t Uart0<RxSize, TxSize>::kRxCapacity;
template <uint16_t RxSize, uint16_t TxSize>
constexpr uint8_t Uart0<RxSize, TxSize>::kTxCapacity;
template <uint16_t RxSize, uint16_t TxSize>
ByteRing<RxSize> Uart0<RxSize, TxSize>::rx_;
template <uint16_t RxSize, uint16_t TxSize>
ByteRing<TxSize> Uart0<RxSize, TxSize>::tx_;
template <uint16_t RxSize, uint16_t TxSize>
UartCounters Uart0<RxSize, TxSize>::counters_;
template <uint16_t RxSize, uint16_t TxSize>
bool Uart0<RxSize, TxSize>::written_;
template <uint16_t RxSize, uint16_t TxSize>
uint8_t Uart0<RxSize, TxSize>::ucsr0a_;

}  // namespace firmware
}  // namespace tether

/// Defines USART_RX_vect and USART_UDRE_vect for the `Uart0<...>` type given (a type alias or the
/// template-id itself). Use once per image, at global namespace scope, before the type's `begin()`
/// is called in that file.
#define TETHER_UART0_ISRS(...)                                                       \
  namespace tether {                                                                 \
  namespace firmware {                                                               \
  template <>                                                                        \
  const uint8_t __VA_ARGS__::interrupts_defined_by_TETHER_UART0_ISRS = 1;            \
  }                                                                                  \
  }                                                                                  \
  ISR(USART_RX_vect, ISR_NAKED) { __VA_ARGS__::rx_handler(); }                        \
  ISR(USART_UDRE_vect, ISR_NAKED) { __VA_ARGS__::udre_handler(); }                    \
  static_assert(true, "swallows the semicolon after the macro")
