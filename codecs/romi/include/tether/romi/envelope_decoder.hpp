/// @file envelope_decoder.hpp
/// Incremental Romi envelope decoder, shared by Tether firmware (requests) and hosts (responses, logs).
///
/// Feed it bytes as they arrive, one call per byte; each call returns at most one event. It never blocks
/// and never allocates; `Capacity` bounds the frame (payload, ':' and the 4 metadata characters).
///
/// Framing rules (the reference's, made precise):
///   1. Bytes before `#` are ignored (counted as a resync). `#` starts a frame anywhere, also inside one:
///      the half frame before it is dropped (counted).
///   2. The metadata is the 4 characters after the LAST ':' of the line, so log text may contain ':'.
///   3. `\r` or `\n` before any ':' is -6 (missing metadata). Metadata that is not 4 characters: fewer is
///      -2 (invalid id: `#e:\r\n`), more is -5 (expected end). `xxxx` marks a manual frame (no id, no CRC
///      check); another 'x' pattern is -7. Otherwise the id must be two lowercase hex digits (-2) and the
///      CRC too (-3). After the metadata comes `\r\n` (-5 otherwise). A wrong CRC is -4.
///   4. A frame longer than `Capacity` is -1, reported once; the decoder then waits for the next `#`.
///   5. After an error the offending byte is consumed and the decoder waits for the next `#`.
/// Error events carry what was parsed so far (opcode character, id when its two digits were valid), so a
/// device can answer with the right opcode and id.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/romi/errors.hpp"

namespace tether {
namespace romi {

/// What one byte produced.
struct EnvelopeEvent {
  /// Event kinds.
  enum class Kind : uint8_t {
    none,     ///< Nothing complete yet.
    frame,    ///< A complete frame that is not a log line: `payload` is opcode + arguments/values.
    log,      ///< A log line: `payload` is its text (after `#!`).
    error,    ///< A damaged frame: `error` says why.
  };
  Kind kind = Kind::none;           ///< What happened.
  ErrorCode error = ErrorCode::no_error;  ///< For `error`.
  ByteView payload;                 ///< For frame/log: view into the decoder, valid until the next feed.
  bool manual = false;              ///< `xxxx` metadata: no id, CRC not checked.
  bool has_id = false;              ///< `id` is valid (always for a non-manual frame).
  uint8_t id = 0;                   ///< The frame's id.
  char opcode = '_';                ///< First payload character, or '_' when the frame had none.
  /// For `error`: the damaged frame began `#!`: a log line, not an answer, so a host waiting for an
  /// answer does not take it for a lost one.
  bool log_line = false;
};

/// Envelope decoder for frames of at most `Capacity` bytes between `#` and `\r`.
template <size_t Capacity>
class EnvelopeDecoder {
  static_assert(Capacity >= 8, "a frame needs room for an opcode and its metadata");

 public:
  /// Decoder counting into `counters` (frames_ok, crc_errors, framing_errors, oversize_frames,
  /// resyncs); `counters` must outlive it.
  explicit EnvelopeDecoder(LinkCounters& counters) : counters_(&counters) {}

  /// Consumes one byte.
  EnvelopeEvent feed(uint8_t byte);
  /// Forgets the frame in progress (e.g. its deadline passed); waits for the next `#`.
  void reset() {
    state_ = State::idle;
    size_ = 0;
    pending_ = EnvelopeEvent();
  }
  /// True between a `#` and the end of that frame: what a partial-frame deadline watches.
  bool in_frame() const { return state_ != State::idle; }

 private:
  enum class State : uint8_t { idle, body, expect_lf, skip };

  EnvelopeEvent finish_line(uint8_t end);
  EnvelopeEvent fail(ErrorCode code);

  LinkCounters* counters_;
  State state_ = State::idle;
  uint8_t buffer_[Capacity];
  size_t size_ = 0;
  size_t last_colon_ = 0;
  bool seen_colon_ = false;
  bool skipping_ = false;  // bytes are being ignored: the next '#' counts as a resync
  EnvelopeEvent pending_;  // a complete frame waiting for its '\n'
};

}  // namespace romi
}  // namespace tether

#include "tether/romi/envelope_decoder_impl.hpp"
