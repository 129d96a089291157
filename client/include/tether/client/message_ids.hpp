/// @file message_ids.hpp
/// The 32-bit message ids of a client whose device runs each id at most once by remembering the last few
/// it ran (its duplicate filter: `session::DuplicateFilter`), as the proxy and rpc devices do.
///
/// Ids come from a wrapping sequence that skips 0 and the ids still in flight. A message waiting for its
/// ack may be sent again; the device must still remember it then, or it would run it twice. After a
/// message X first runs, the device may still run for the first time an older id that was in flight when
/// X was sent (its first copy lost, or still on the way), and every id sent after X. So each message keeps
/// an anchor, the oldest id in flight when it was first sent (its own id if none was), and a new id goes
/// out only while it stays within `window` consecutive ids of every unacked message's anchor: at most
/// `window - 1` other ids run between X and its re-send. Distances are in sequence order (ids wrap at 2^32).
#pragma once

#include <algorithm>
#include <cstdint>

namespace tether::client {

/// A client's message-id sequence and its window check; see the file overview. Plain data, strand only.
class MessageIds {
 public:
  /// The sequence whose first id is `first` (0 is skipped); `window` is the device's remembered ids (>= 1).
  MessageIds(std::uint32_t first, std::uint8_t window) : last_(first - 1), window_(window) {}

  /// The next id not `in_flight(id)`, skipping 0, which becomes the last id handed out.
  template <typename InFlight>
  std::uint32_t next(const InFlight& in_flight) {
    last_ = peek(in_flight);
    return last_;
  }
  /// What `next` would hand out.
  template <typename InFlight>
  std::uint32_t peek(const InFlight& in_flight) const {
    std::uint32_t id = last_;
    do {
      ++id;
    } while (id == 0 || in_flight(id));
    return id;
  }
  /// The last id handed out.
  std::uint32_t last() const { return last_; }

  /// The anchor of an id just handed out while `in_flight_ids` (a range of ids, it not among them) are
  /// unacked: the oldest of them, or the id itself when there is none.
  template <typename Ids>
  std::uint32_t anchor(std::uint32_t id, const Ids& in_flight_ids) const {
    std::uint32_t oldest = id;
    std::uint32_t oldest_distance = 0;
    for (const std::uint32_t other : in_flight_ids) {
      const auto distance = static_cast<std::uint32_t>(last_ - other);
      if (distance >= oldest_distance) {
        oldest_distance = distance;
        oldest = other;
      }
    }
    return oldest;
  }

  /// True when the next id keeps every unacked message within the window: `anchors` are their anchors (a
  /// range; empty: always true), `in_flight` what `next` skips.
  template <typename Anchors, typename InFlight>
  bool window_open(const Anchors& anchors, const InFlight& in_flight) const {
    bool any = false;
    std::uint32_t anchor_distance = 0;
    for (const std::uint32_t anchor : anchors) {
      any = true;
      anchor_distance = std::max(anchor_distance, static_cast<std::uint32_t>(last_ - anchor));
    }
    if (!any) return true;
    return anchor_distance + static_cast<std::uint32_t>(peek(in_flight) - last_) < window_;
  }

 private:
  std::uint32_t last_;
  std::uint8_t window_;
};

}  // namespace tether::client
