/// @file frame.hpp
/// The proxy frame's writer (encoder.hpp) and reader (decoder.hpp), plus the reader's deprecated names
/// from before the codecs shared one event model: kept for one release so that code written against them
/// still builds (with a deprecation warning), removed in the next. New code includes encoder.hpp or
/// decoder.hpp and uses `proxy::Decoder`, whose `feed` returns a `DecodeStatus`.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/status.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"

namespace tether {
namespace proxy {

/// Deprecated: what one byte produced (now `DecodeStatus` plus `Decoder::frame()` / `error()`).
struct [[deprecated("use proxy::Decoder: feed() returns a DecodeStatus, then read frame() or error()")]] FrameEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,     ///< Nothing complete.
    payload,  ///< A checked payload in `payload`.
    error,    ///< A frame was dropped: `status` is frame_too_long, framing_error or crc_mismatch.
  };
  Kind kind = Kind::none;      ///< What happened.
  Status status = Status::ok;  ///< For `error`.
  ByteView payload;            ///< For `payload`: view into the decoder, valid until the next feed.
};

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
/// Deprecated: `Decoder` returning an event struct per byte.
template <size_t MaxPayload>
class [[deprecated("use proxy::Decoder")]] FrameDecoder {
 public:
  /// See `Decoder`.
  FrameDecoder(Integrity integrity, LinkCounters& counters) : decoder_(integrity, counters) {}
  /// Consumes one byte; the event it produced.
  FrameEvent feed(uint8_t byte) {
    FrameEvent event;
    const DecodeStatus status = decoder_.feed(byte);
    if (status == DecodeStatus::frame) {
      event.kind = FrameEvent::Kind::payload;
      event.payload = decoder_.frame();
    } else if (status == DecodeStatus::error) {
      event.kind = FrameEvent::Kind::error;
      event.status = decoder_.error() == FrameError::frame_too_long  ? Status::frame_too_long
                     : decoder_.error() == FrameError::crc_mismatch ? Status::crc_mismatch
                                                                     : Status::framing_error;
    }
    return event;
  }
  /// See `Decoder::reset`.
  void reset() { decoder_.reset(); }
  /// See `Decoder::in_frame`.
  bool in_frame() const { return decoder_.in_frame(); }

 private:
  Decoder<MaxPayload> decoder_;
};
#pragma GCC diagnostic pop

}  // namespace proxy
}  // namespace tether
