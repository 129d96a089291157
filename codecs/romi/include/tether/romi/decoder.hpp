/// @file decoder.hpp
/// Incremental Romi envelope decoder, shared by Tether firmware (requests) and hosts (responses, logs).
///
/// Feed it bytes as they arrive (`feed(byte)`, or `feed(bytes)` which stops at the first frame or error);
/// each byte returns a `DecodeStatus` (core/decode_status.hpp); on `frame` or `error` read `frame()` or
/// `error()` before the next feed. It never blocks and never allocates; `Capacity` bounds the frame
/// (payload, ':' and the 4 metadata characters). `Decoder<kRunTimeCapacity>` takes its buffer and its
/// capacity at run time instead (`use_buffer`), so decoders of different capacities share one copy of
/// the code (a firmware's Romi devices of several sizes).
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
/// After an error `frame()` keeps what was parsed so far (opcode character, id when its two digits were
/// valid, whether it was a log line), so a device can answer with the right opcode and id.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/romi/errors.hpp"

namespace tether {
namespace romi {

/// A decoded frame, or after an error what was parsed of the damaged one.
struct Frame {
  /// Answer or request: opcode + arguments/values; log line: its text (after `#!`). Empty after an
  /// error. A view into the decoder, valid until the next feed.
  ByteView payload;
  /// The frame began `#!`: a log line, not an answer (after an error too, so a host waiting for an answer
  /// does not take a damaged log line for a lost answer).
  bool log = false;
  bool manual = false;  ///< `xxxx` metadata: no id, CRC not checked.
  bool has_id = false;  ///< `id` is valid (always for a complete non-manual frame).
  uint8_t id = 0;       ///< The frame's id; 0 when `has_id` is false.
  char opcode = '_';    ///< First payload character of a non-log frame, or '_' when there was none.
};

/// The `Capacity` of a `Decoder` whose buffer is given at run time (`Decoder::use_buffer`).
constexpr size_t kRunTimeCapacity = 0;

namespace detail {

/// A decoder's frame buffer: inside the decoder, `Capacity` bytes. Positions in 8 bits when they fit
/// (the AVR handles a 16-bit index in two instructions a step).
template <size_t Capacity, bool Small = (Capacity < 256)>
struct DecoderBuffer {
  using Index = size_t;
  static constexpr Index capacity() { return Capacity; }
  uint8_t* data() { return bytes_; }
  const uint8_t* data() const { return bytes_; }
  uint8_t bytes_[Capacity];
};
template <size_t Capacity>
struct DecoderBuffer<Capacity, true> {
  using Index = uint8_t;
  static constexpr Index capacity() { return static_cast<Index>(Capacity); }
  uint8_t* data() { return bytes_; }
  const uint8_t* data() const { return bytes_; }
  uint8_t bytes_[Capacity];
};
/// A buffer given at run time (`kRunTimeCapacity`): its address and capacity (at most 255).
template <>
struct DecoderBuffer<kRunTimeCapacity, true> {
  using Index = uint8_t;
  Index capacity() const { return capacity_; }
  uint8_t* data() { return data_; }
  const uint8_t* data() const { return data_; }
  uint8_t* data_ = nullptr;
  Index capacity_ = 0;
};

}  // namespace detail

/// Envelope decoder for frames of at most `Capacity` bytes between `#` and `\r` (`kRunTimeCapacity`: as
/// many as the buffer given to `use_buffer`). `Counters` is where it counts: `LinkCounters`, or any
/// struct with its fields frames_ok, crc_errors, framing_errors, oversize_frames and resyncs (a device
/// keeps only the counters it uses: RAM is scarce there).
template <size_t Capacity, typename Counters = LinkCounters>
class Decoder {
  static_assert(Capacity == kRunTimeCapacity || Capacity >= 8, "a frame needs room for an opcode and its metadata");

 public:
  /// Decoder counting into `counters` (frames_ok, crc_errors, framing_errors, oversize_frames,
  /// resyncs); `counters` must outlive it.
  explicit Decoder(Counters& counters) : counters_(&counters) {}
  /// Decoder without counters yet: call `count_into` before the first feed. For a decoder that is a
  /// member of a zero-filled state (a device's: one clearing loop instead of a store per member).
  Decoder() = default;
  /// Counts into `counters` from now on; `counters` must outlive the decoder.
  void count_into(Counters& counters) { counters_ = &counters; }
  /// `Decoder<kRunTimeCapacity>` only: frames go into `buffer`, `capacity` bytes (6 at least: an opcode,
  /// ':' and the metadata), which must outlive the decoder. Call it before the first feed.
  template <size_t C = Capacity>
  void use_buffer(uint8_t* buffer, uint8_t capacity) {
    static_assert(C == kRunTimeCapacity, "only a Decoder<kRunTimeCapacity> takes its buffer at run time");
    buffer_.data_ = buffer;
    buffer_.capacity_ = capacity;
  }
  /// The most bytes a frame may have between `#` and `\r`.
  size_t capacity() const { return buffer_.capacity(); }
  /// The frame buffer (`capacity()` bytes; with `kRunTimeCapacity`, the one given to `use_buffer`).
  uint8_t* buffer() { return buffer_.data(); }

  /// Consumes one byte.
  DecodeStatus feed(uint8_t byte);
  /// Consumes `byte` and returns true when it is an ordinary byte inside a frame's body (the common
  /// case: stored, status `more`, nothing else happens); false, consuming nothing, for any other byte,
  /// which the caller then gives to `feed_special`. Small enough to inline into a device's byte loop.
  bool feed_body(uint8_t byte);
  /// Consumes the ordinary body bytes at the start of `bytes[0..count)` exactly as `feed_body` would one
  /// by one, and returns how many (0 when the first is not one, or no frame is open); the byte after them
  /// goes to `feed_special`. A device's byte loop: the frame's position stays in a register for the run.
  uint8_t feed_body_run(const uint8_t* bytes, uint8_t count);
  /// Consumes a `#`, as `feed_special('#')` does (a new frame starts, whatever came before it is dropped),
  /// inline: a device that tells a `#` apart itself starts its frame without `feed_special`'s call.
  void feed_hash();
  /// Consumes a byte `feed_body` refused (frame start and end, errors, bytes outside frames). Out of
  /// line: the rare cases must not weigh on the inlined per-byte path.
  __attribute__((noinline)) DecodeStatus feed_special(uint8_t byte);
  /// Consumes `bytes` up to and including the first one that completes a frame or an error, with exactly
  /// the results of feeding them one at a time. A frame's body bytes are taken by `feed_body_run`, the
  /// write position in a register (the host's cost per frame; a byte store may alias the
  /// members, so byte by byte they are reloaded after every byte). Prefer it wherever bytes arrive in runs.
  FeedResult feed(ByteView bytes);
  /// After `frame`: the frame; after `error`: what was parsed of it (see the file overview).
  const Frame& frame() const { return frame_; }
  /// After `error`: why the frame was dropped.
  Error error() const { return static_cast<Error>(error_); }
  /// Forgets the frame in progress (e.g. its deadline passed); waits for the next `#`.
  void reset() {
    state_ = State::idle;
    size_ = 0;
    frame_ = Frame();
  }
  /// Forgets the frame in progress as `reset()` does, but `frame()` then holds its opcode so far
  /// (`partial_opcode()`) and no id: what a device's answer to the dropped frame echoes.
  void abandon() {
    const char opcode = partial_opcode();
    reset();
    frame_.opcode = opcode;
  }
  /// True between a `#` and the end of that frame, also while the rest of a failed frame is skipped.
  bool in_frame() const { return state_ != State::idle; }
  /// True between a `#` and the byte that completes the frame or fails it: a request is being received
  /// (what a partial-frame deadline watches: nothing is pending before the `#` or after that byte).
  bool receiving() const { return state_ >= State::body; }
  /// True after a frame's `\r` when its metadata checked out: only the `\n` is missing, and `frame()`
  /// already holds the frame, so a device can do the frame's work before its last byte arrives.
  bool awaiting_end() const { return state_ == State::expect_lf; }
  /// While in a frame: its opcode so far (its first byte when that is an opcode character, else '_').
  char partial_opcode() const;

 private:
  // receiving(): body and expect_lf last.
  enum class State : uint8_t { idle, skip, body, expect_lf };
  using Buffer = detail::DecoderBuffer<Capacity>;
  using Index = typename Buffer::Index;

  // Out of line (a GCC/Clang attribute), as feed_special.
  __attribute__((noinline)) DecodeStatus finish_line(uint8_t end);
  __attribute__((noinline)) DecodeStatus fail(Error error);

  Counters* counters_ = nullptr;
  State state_ = State::idle;
  int8_t error_ = 0;  // an Error, -1..-7 (a byte: a device keeps the decoder in its RAM)
  Buffer buffer_;
  Index size_ = 0;
  Index last_colon_ = 0;
  bool seen_colon_ = false;
  bool skipping_ = false;  // bytes are being ignored: the next '#' counts as a resync
  Frame frame_;            // the frame being completed (waiting for its '\n'), complete, or failed
};

}  // namespace romi
}  // namespace tether

#include "tether/romi/decoder_impl.hpp"
