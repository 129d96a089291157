/// @file byte_ring.hpp
/// Single-producer, single-consumer byte ring shared between one interrupt handler and the main loop.
///
/// The ring keeps two free-running 8-bit counters: `head` (bytes ever written) and `tail` (bytes ever
/// read), both modulo 256. Each counter has exactly one writer, and an 8-bit load or store is atomic on
/// the AVR, so neither side needs to disable interrupts to look at the other's counter. Because the size
/// divides 256, `counter & mask` stays a valid index across the wrap and `head - tail` (cast back to
/// 8 bits) is the fill level. Size 256 therefore holds at most 255 bytes: a full 256-byte ring would read
/// as empty.
///
/// Main-loop code must put `compiler_barrier()` between touching `bytes` and publishing its counter:
/// `bytes` is not volatile (bulk copies stay fast), so without the barrier the compiler could move the
/// copy past the volatile counter store and the interrupt would see a counter ahead of the data.
/// Inside an interrupt handler no barrier is needed: the main loop cannot run until the handler returns.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {
namespace firmware {

/// Stops the compiler from moving memory accesses across this point (emits no instruction).
inline void compiler_barrier() { __asm__ __volatile__("" ::: "memory"); }

/// Byte ring of `Size` slots (a power of two, 2..256). Plain data: lives in static storage, zeroed.
template <uint16_t Size>
struct ByteRing {
  static_assert(Size >= 2 && Size <= 256 && (Size & (Size - 1u)) == 0,
                "ring size must be a power of two between 2 and 256");

  /// Maps a free-running counter to a slot.
  static constexpr uint8_t kMask = static_cast<uint8_t>(Size - 1u);
  /// Bytes the ring can hold: `Size`, except 255 for 256 (see the file comment).
  static constexpr uint8_t kCapacity = static_cast<uint8_t>(Size == 256u ? 255u : Size);

  uint8_t bytes[Size];     ///< Storage; slot of counter `c` is `bytes[c & kMask]`.
  volatile uint8_t head;   ///< Bytes ever written (mod 256); written by the producer only.
  volatile uint8_t tail;   ///< Bytes ever read (mod 256); written by the consumer only.

  /// Bytes stored now. A snapshot: the other side may change it right after.
  uint8_t used() const { return static_cast<uint8_t>(head - tail); }
  /// Bytes that can be stored now.
  uint8_t space() const { return static_cast<uint8_t>(kCapacity - used()); }
  /// True when nothing is stored.
  bool empty() const { return head == tail; }
  /// True when no more bytes fit.
  bool full() const { return used() == kCapacity; }
};

template <uint16_t Size>
constexpr uint8_t ByteRing<Size>::kMask;
template <uint16_t Size>
constexpr uint8_t ByteRing<Size>::kCapacity;

}  // namespace firmware
}  // namespace tether
