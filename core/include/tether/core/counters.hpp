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
/// has a dozen of them (issue 17: romi-bench's flash). Not for interrupt handlers: a call there makes the
/// handler save every call-clobbered register.
#if defined(__AVR__)
__attribute__((noinline)) inline void add_one(uint32_t& counter) { ++counter; }
#else
inline void add_one(uint32_t& counter) { ++counter; }
#endif

}  // namespace tether
