/// @file duplicate_filter.hpp
/// Device half of exactly-once: recognise a re-sent request and answer it from a cache.
///
/// The host re-sends a request with the same id when it did not get (or could not check) the reply. The
/// device must not execute it twice: it looks the request up here first. A request counts as a repeat
/// when both its id and its fingerprint (a checksum of the request's bytes, e.g. its CRC) match one of
/// the last `Depth` requests executed; the fingerprint keeps a new host session that restarts its ids from
/// zero from getting an old reply to a different command. The reply bytes of each remembered request are
/// kept (up to `ReplyCapacity` bytes) so the device can send the very same reply again.
///
/// The proxy device uses it with Depth >= the host's requests in flight and no reply bytes (its reply, an
/// Ack, is rebuilt from the id). The Romi device does not: with one entry it keeps the request's own bytes
/// as an exact key and its reply in the buffer it formed it in (romi_serial.cpp), which costs less RAM than
/// a fingerprint beside a separate reply copy.
#pragma once

#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/status.hpp"

namespace tether {
namespace session {

/// Recent-request memory of a device. No heap: `Depth * ReplyCapacity` bytes inside.
template <typename Id, uint8_t Depth, uint16_t ReplyCapacity>
class DuplicateFilter {
  static_assert(Depth >= 1, "remember at least one request");

 public:
  /// Answer of `check`.
  struct Lookup {
    bool duplicate = false;  ///< The request was executed already: do not execute it again.
    ByteView cached_reply;   ///< Its reply as first sent (empty when none was cached).
  };

  /// Empty filter; `counters` (outliving it) receives duplicates.
  constexpr explicit DuplicateFilter(LinkCounters& counters) : counters_(&counters), entries_{} {}

  /// Looks up a request before executing it. Counts a duplicate when found.
  Lookup check(Id id, uint16_t fingerprint) {
    Lookup lookup;
    for (uint8_t i = 0; i < count_; ++i) {
      const Entry& entry = entries_[i];
      if (entry.id == id && entry.fingerprint == fingerprint) {
        ++counters_->duplicates;
        lookup.duplicate = true;
        lookup.cached_reply = entry.reply();
        return lookup;
      }
    }
    return lookup;
  }

  /// Records an executed request and its reply; the oldest entry goes when full. A reply longer than
  /// `ReplyCapacity` is not cached (the request is still remembered) and `Status::buffer_too_small` says so.
  Status remember(Id id, uint16_t fingerprint, ByteView reply) {
    Entry& entry = entries_[next_];
    next_ = static_cast<uint8_t>((next_ + 1) % Depth);
    if (count_ < Depth) ++count_;
    entry.id = id;
    entry.fingerprint = fingerprint;
    const bool fits = entry.keep(reply);
    return fits ? Status::ok : Status::buffer_too_small;
  }

  /// Forgets everything (e.g. after a manual request that has no id of its own).
  void clear() {
    count_ = 0;
    next_ = 0;
  }
  /// Requests remembered.
  uint8_t size() const { return count_; }

 private:
  // A remembered request's reply bytes; none at all (not even a size) without a reply capacity: the
  // proxy device's 8 entries are then 6 bytes each instead of 9.
  // Its size in one byte when the capacity allows (a byte less per entry; no <type_traits> on the AVR).
  template <bool kSmall, int kUnused = 0>
  struct ReplySize {
    using type = uint8_t;
  };
  template <int kUnused>
  struct ReplySize<false, kUnused> {
    using type = uint16_t;
  };
  template <uint16_t Capacity, bool kKept = (Capacity > 0)>
  struct Reply {
    using Size = typename ReplySize<(Capacity < 256)>::type;
    Size size = 0;
    uint8_t bytes[Capacity] = {};
    ByteView reply() const { return ByteView(bytes, size); }
    // Keeps `reply` when it fits (else an empty one); false when it did not fit.
    bool keep(ByteView reply) {
      const bool fits = reply.size() <= Capacity;
      size = static_cast<Size>(fits ? reply.size() : 0);
      for (uint16_t i = 0; i < size; ++i) bytes[i] = reply[i];
      return fits;
    }
  };
  template <uint16_t Capacity>
  struct Reply<Capacity, false> {
    ByteView reply() const { return ByteView(); }
    bool keep(ByteView reply) const { return reply.empty(); }
  };
  struct Entry : Reply<ReplyCapacity> {
    Id id = 0;
    uint16_t fingerprint = 0;
  };

  LinkCounters* counters_;
  Entry entries_[Depth];
  uint8_t count_ = 0;
  uint8_t next_ = 0;
};

}  // namespace session
}  // namespace tether
