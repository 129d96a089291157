/// @file envelope_decoder.hpp
/// Deprecated: the Romi decoder's names before the codecs shared one event model (decoder.hpp). Kept
/// for one release so that code written against them still builds (with a deprecation warning); removed
/// in the next. New code: `romi::Decoder`, whose `feed` returns a `DecodeStatus`.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/romi/decoder.hpp"

namespace tether {
namespace romi {

/// Deprecated: what one byte produced (now `DecodeStatus` plus `Decoder::frame()` / `error()`).
struct [[deprecated("use romi::Decoder: feed() returns a DecodeStatus, then read frame() or error()")]] EnvelopeEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,   ///< Nothing complete yet.
    frame,  ///< A complete frame that is not a log line.
    log,    ///< A log line.
    error,  ///< A damaged frame: `error` says why.
  };
  Kind kind = Kind::none;           ///< What happened.
  Error error = Error::no_error;    ///< For `error`.
  ByteView payload;                 ///< For frame/log: view into the decoder, valid until the next feed.
  bool manual = false;              ///< `xxxx` metadata: no id, CRC not checked.
  bool has_id = false;              ///< `id` is valid.
  uint8_t id = 0;                   ///< The frame's id.
  char opcode = '_';                ///< First payload character, or '_'.
  bool log_line = false;            ///< For `error`: the damaged frame began `#!`.
};

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
/// Deprecated: `Decoder` returning an event struct per byte.
template <size_t Capacity>
class [[deprecated("use romi::Decoder")]] EnvelopeDecoder {
 public:
  /// See `Decoder`.
  explicit EnvelopeDecoder(LinkCounters& counters) : decoder_(counters) {}
  /// Consumes one byte; the event it produced.
  EnvelopeEvent feed(uint8_t byte) {
    EnvelopeEvent event;
    const DecodeStatus status = decoder_.feed(byte);
    if (status == DecodeStatus::more) return event;
    const Frame& frame = decoder_.frame();
    event.has_id = frame.has_id;
    event.id = frame.id;
    event.opcode = frame.opcode;
    if (status == DecodeStatus::error) {
      event.kind = EnvelopeEvent::Kind::error;
      event.error = decoder_.error();
      event.log_line = frame.log;
      return event;
    }
    event.kind = frame.log ? EnvelopeEvent::Kind::log : EnvelopeEvent::Kind::frame;
    event.payload = frame.payload;
    event.manual = frame.manual;
    return event;
  }
  /// See `Decoder::reset`.
  void reset() { decoder_.reset(); }
  /// See `Decoder::in_frame`.
  bool in_frame() const { return decoder_.in_frame(); }

 private:
  Decoder<Capacity> decoder_;
};
#pragma GCC diagnostic pop

}  // namespace romi
}  // namespace tether
