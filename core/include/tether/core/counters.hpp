/// @file counters.hpp
/// Link diagnostics: the counters every codec and the session engine keep, as part of the public API.
///
/// One struct for all protocols so that tools (`tether stats`, the demo table, benchmarks) read every
/// device the same way. Counters only grow (they wrap at 2^32); a codec increments those that apply to it
/// and leaves the rest at zero. Each field says who increments it.
#pragma once

#include <stdint.h>

namespace tether {

/// Counters of one link. Plain data: copy it to take a snapshot.
struct LinkCounters {
  uint32_t frames_ok = 0;         ///< Decoder: frames that passed every check and were delivered.
  uint32_t crc_errors = 0;        ///< Decoder: frames dropped for a checksum mismatch.
  uint32_t framing_errors = 0;    ///< Decoder: frames dropped as malformed (bad syntax, bad COBS, ...).
  uint32_t oversize_frames = 0;   ///< Decoder: frames dropped for exceeding the size bound.
  uint32_t resyncs = 0;           ///< Decoder: times it skipped garbage to find the next frame start.
  uint32_t partial_timeouts = 0;  ///< Device engine: partial frames dropped at their deadline.
  uint32_t stale = 0;             ///< Host engine: replies whose id was not in flight (dropped).
  uint32_t duplicates = 0;        ///< Device engine: repeated request ids answered from the cache.
  uint32_t retries = 0;           ///< Host engine: re-sends of a request with the same id.
  uint32_t timeouts = 0;          ///< Host engine: calls that ran out of attempt or budget time.
  uint32_t resets = 0;            ///< Host engine: device resets detected (session changed).
  uint32_t failsafes = 0;         ///< Device engine: failsafe activations after heartbeat silence.
};

/// Adds one to a diagnostics counter (counters wrap at 2^32). The codecs' decoders and the device
/// libraries count through it. On the AVR it is out of line: an inline 32-bit increment of a member is
/// 24 to 38 bytes of flash (four loads, an add with carries, four stores) where a call is 6, and a device
/// has a dozen of them (romi-bench's flash). Not for interrupt handlers: a call there makes the
/// handler save every call-clobbered register (`add_one_in_interrupt` is theirs).
#if defined(__AVR__)
__attribute__((noinline)) inline void add_one(uint32_t& counter) { ++counter; }
#else
inline void add_one(uint32_t& counter) { ++counter; }
#endif

/// Adds one to a 32-bit counter from an interrupt handler (the UART's error counters, the millisecond
/// tick), where `add_one`'s call would make the handler save every call-clobbered register on every
/// interrupt. On the AVR the carry ripples through the counter's bytes in a loop that stops at the first
/// byte that does not wrap: 18 bytes of flash and ~10 cycles where an inline `++` is 38 bytes and 20
/// cycles (in assembly: avr-gcc makes the loop larger, and larger still for a volatile counter). Volatile,
/// so that the millisecond tick (read by the main program) can use it too.
__attribute__((always_inline)) inline void add_one_in_interrupt(volatile uint32_t& counter) {
#if defined(__AVR__)
  volatile uint32_t* at = &counter;  // little-endian: the lowest byte first
  uint8_t left = sizeof counter;
  asm volatile(
      "1: ld __tmp_reg__, %a[at]\n\t"
      "inc __tmp_reg__\n\t"  // sets Z when the byte wrapped: the carry goes on
      "st %a[at]+, __tmp_reg__\n\t"
      "brne 2f\n\t"
      "dec %[left]\n\t"
      "brne 1b\n"
      "2:"
      : [at] "+e"(at), [left] "+r"(left)
      :
      : "memory");
#else
  counter = counter + 1u;
#endif
}

/// Adds one to a counter on a hot path of the main program (a device's per-request counters), inline:
/// on the AVR the same carry loop as `add_one_in_interrupt` (~10 cycles, where an inline `++` of a member
/// is ~24 and `add_one`'s call ~25); elsewhere `++`.
__attribute__((always_inline)) inline void add_one_inline(uint32_t& counter) {
#if defined(__AVR__)
  add_one_in_interrupt(counter);
#else
  ++counter;
#endif
}

}  // namespace tether
