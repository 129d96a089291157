/// @file decode_status.hpp
/// The one event model of every incremental decoder (Romi, proxy, Elcano): `feed(byte)` returns a
/// one-byte `DecodeStatus`; the completed frame or the error is then read from the decoder (`frame()`,
/// `error()`), valid until the next feed.
///
/// Why a status and not an event struct per byte: on the AVR a returned struct is built, copied and
/// tested for every byte of the stream, while a frame completes once per tens of bytes; one byte in a
/// register costs nothing. `feed(ByteView)` on each decoder feeds many bytes and stops at the first frame
/// or error (`FeedResult::consumed` says where), so a host read loop handles every event in order.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"

namespace tether {

/// What the bytes fed so far produced.
enum class DecodeStatus : uint8_t {
  more = 0,  ///< Nothing complete yet: feed more bytes.
  frame,     ///< A frame completed: read it with the decoder's `frame()` before the next feed.
  error,     ///< A frame was dropped: the decoder's `error()` says why (already counted).
};

/// Outcome of feeding a span: the status of the last byte used, and how many bytes were used.
struct FeedResult {
  DecodeStatus status;  ///< `frame` or `error` when the span stopped early; `more` when all was used.
  size_t consumed;      ///< Bytes used from the span's front; feed the rest after reading the event.
};

/// Feeds `bytes` to `decoder` one at a time and stops after the first byte that completes a frame or
/// reports an error. Every decoder's `feed(ByteView)` is this, so span feeding behaves exactly as
/// byte-at-a-time feeding.
template <typename Decoder>
FeedResult feed_until_event(Decoder& decoder, ByteView bytes) {
  for (size_t i = 0; i < bytes.size(); ++i) {
    const DecodeStatus status = decoder.feed(bytes[i]);
    if (status != DecodeStatus::more) return FeedResult{status, i + 1};
  }
  return FeedResult{DecodeStatus::more, bytes.size()};
}

}  // namespace tether
