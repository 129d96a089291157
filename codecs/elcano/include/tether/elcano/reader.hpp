/// @file reader.hpp
/// Deprecated: the Elcano decoder's names before the codecs shared one event model (decoder.hpp). Kept
/// for one release so that code written against them still builds (with a deprecation warning); removed
/// in the next. New code: `elcano::Decoder`, whose `feed` returns a `DecodeStatus`.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/elcano/decoder.hpp"

namespace tether {
namespace elcano {

/// Deprecated: what one byte produced (now `DecodeStatus` plus `Decoder::frame()` / `error()`).
struct [[deprecated("use elcano::Decoder: feed() returns a DecodeStatus, then read frame() or error()")]] ReadEvent {
  /// Event kinds.
  enum class Kind : uint8_t { none, message, error };
  Kind kind = Kind::none;          ///< What happened.
  Error error = Error::success;    ///< For `error`.
  Message message;                 ///< For `message`.
  ByteView forward;                ///< For `message`: its bytes to forward (valid until next feed).
};

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
/// Deprecated: `Decoder` under its old name and API.
template <size_t Capacity = 96>
class [[deprecated("use elcano::Decoder")]] Reader {
 public:
  /// See `Decoder`.
  Reader(Generation generation, LinkCounters& counters) : decoder_(generation, counters) {}
  /// Consumes one byte; the whole event by value.
  ReadEvent feed(uint8_t byte) {
    ReadEvent event;
    event.kind = consume(byte);
    if (event.kind == ReadEvent::Kind::message) {
      event.message = decoder_.frame();
      event.forward = decoder_.forward();
    } else if (event.kind == ReadEvent::Kind::error) {
      event.error = decoder_.error();
    }
    return event;
  }
  /// Consumes one byte (now `Decoder::feed`).
  ReadEvent::Kind consume(uint8_t byte) {
    const DecodeStatus status = decoder_.feed(byte);
    return status == DecodeStatus::frame   ? ReadEvent::Kind::message
           : status == DecodeStatus::error ? ReadEvent::Kind::error
                                           : ReadEvent::Kind::none;
  }
  /// Now `Decoder::frame`.
  const Message& message() const { return decoder_.frame(); }
  /// See `Decoder::forward`.
  ByteView forward() const { return decoder_.forward(); }
  /// See `Decoder::error`.
  Error error() const { return decoder_.error(); }
  /// See `Decoder::reset`.
  void reset() { decoder_.reset(); }
  /// Now `Decoder::in_frame`.
  bool in_message() const { return decoder_.in_frame(); }

 private:
  Decoder<Capacity> decoder_;
};
#pragma GCC diagnostic pop

}  // namespace elcano
}  // namespace tether
