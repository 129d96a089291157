/// @file execution_witness.hpp
/// Exactly-once witness: a device-side count and log of the commands a firmware EXECUTED, which a test or
/// `tether demo` compares with what the host was told (confirmed, failed). Non-idempotent on purpose: a
/// command executed twice is recorded twice, even with the same values, where the pins would look the same.
///
/// Device code calls `witness_executed(key)` at the point where a command takes effect, with a key that
/// tells commands apart (their parameters; each image documents its key). That is a null test and nothing
/// else unless the image links the recorder (firmware/runtime, object library `tether_execution_witness`),
/// which defines the hook and the record `tether_execution_witness` the host reads from a virtual Uno's SRAM
/// (`VirtualUno::symbol` + `read_memory`). Images that do not want the RAM simply do not link it.
///
/// Record (kWitnessRecordSize bytes, byte-addressed so no compiler adds padding):
///   [0]    executed   commands recorded since boot, mod 256 (one byte: the host never sees half a store)
///   [1]    host_mark  0 at boot (.bss); the host writes 1 after a read, so a 0 tells it the device rebooted
///   [2..]  log        key of command n (little-endian uint32) at slot n % kWitnessLogSize, written BEFORE
///                     `executed` counts it, so every counted slot is complete when the host reads it
/// The host reads often enough that fewer than kWitnessLogSize commands run between two reads; more are
/// counted but their keys are lost (the reader reports how many).
#pragma once

#include <stdint.h>

namespace tether {

/// Slots of the device-side log (keys of the last commands executed).
constexpr uint8_t kWitnessLogSize = 8;
/// Offset of the `executed` byte in the record.
constexpr uint8_t kWitnessExecutedOffset = 0;
/// Offset of the `host_mark` byte in the record.
constexpr uint8_t kWitnessHostMarkOffset = 1;
/// Offset of slot 0 of the log.
constexpr uint8_t kWitnessLogOffset = 2;
/// Size of the whole record.
constexpr uint8_t kWitnessRecordSize = kWitnessLogOffset + 4u * kWitnessLogSize;

}  // namespace tether

extern "C" {
/// The recorder's entry point, defined only when the image links `tether_execution_witness` (weak:
/// without it the address is null and `witness_executed` does nothing).
void tether_witness_executed(uint32_t key) __attribute__((weak));
}

namespace tether {

/// Records one execution of the command identified by `key` (no-op without the recorder).
inline void witness_executed(uint32_t key) {
  if (tether_witness_executed != nullptr) tether_witness_executed(key);
}

/// The usual key: two 16-bit command parameters side by side.
inline uint32_t witness_key(uint16_t high, uint16_t low) { return (static_cast<uint32_t>(high) << 16) | low; }

}  // namespace tether
