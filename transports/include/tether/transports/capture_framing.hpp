/// @file capture_framing.hpp
/// How a recording cuts a link's bytes into packets (docs/captures.md): every complete frame of the codec's
/// framing is one packet, and bytes that formed no frame (noise before a start byte, an over-long frame, a
/// partial frame at a close or an outage) are packets of their own, marked `unframed: <reason>`, in stream
/// order. One framer per direction; sans-I/O (bytes in, packets out), bounded by `max_frame`.
///
/// A codec supplies its framing through its row of the codec table (`CodecRow::capture_framing`,
/// devices/codecs.hpp); `DelimitedFramer` covers framings of a start byte set and an end byte (Romi's
/// `#...\n`, Elcano's `D{...}\n`, COBS frames ending in 0x00).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tether::transports {

/// One packet a framer cut: a frame, or a run of unframed bytes with the reason.
struct FramedPacket {
  std::vector<std::uint8_t> bytes;  ///< As they crossed the wire.
  bool frame = true;                ///< False: bytes that formed no frame.
  std::string reason;               ///< For unframed bytes: `noise`, `too long`, `cut at close`, ...
  /// The packet's opt_comment: empty for a frame, `unframed: <reason>` otherwise.
  std::string comment() const { return frame ? std::string() : reason.empty() ? "unframed" : "unframed: " + reason; }
};

/// Called with each packet, in stream order.
using PacketSink = std::function<void(FramedPacket packet)>;

/// Cuts one direction's bytes into packets.
class CaptureFramer {
 public:
  virtual ~CaptureFramer() = default;
  /// Takes the next bytes of the stream (a read or write of any size); hands every packet they complete
  /// to `sink`.
  virtual void feed(std::span<const std::uint8_t> bytes, const PacketSink& sink) = 0;
  /// Hands what is pending (a partial frame, a noise run) to `sink` as unframed bytes with `reason`
  /// (`cut at close`, `cut at outage`): the stream ended or broke there.
  virtual void flush(std::string_view reason, const PacketSink& sink) = 0;
};

/// Makes a framer for one direction (`inbound`: device to host).
using CaptureFraming = std::function<std::unique_ptr<CaptureFramer>(bool inbound)>;

/// A framing of start bytes and an end byte.
struct DelimitedFraming {
  /// Bytes that start a frame; empty: any byte does (COBS, where every byte between delimiters is framed).
  std::string start;
  /// The byte that ends a frame (included in it): `\n`, 0x00.
  std::uint8_t end = '\n';
  /// True when a start byte inside a frame starts a new one (Romi's `#`): the bytes before it are unframed
  /// (`cut by a new frame`).
  bool restart_on_start = false;
  /// True when end bytes in front of a frame belong to it (COBS: a sender's leading 0x00 that flushes line
  /// garbage); false: an end byte outside a frame is noise.
  bool leading_end_bytes = false;
  /// Longest frame, end byte included; longer ones are unframed (`too long`) up to the next end byte (or
  /// start byte, with `restart_on_start`). Unframed runs are cut into packets of at most this size too.
  std::size_t max_frame = 1024;

  /// COBS frames: every non-zero byte is framed, 0x00 ends a frame, leading 0x00s belong to the next frame.
  static DelimitedFraming cobs(std::size_t max_frame) {
    DelimitedFraming framing;
    framing.end = 0;
    framing.leading_end_bytes = true;
    framing.max_frame = max_frame;
    return framing;
  }
  /// Lines from one of the `start` bytes to `\n`; a start byte inside a line starts the next one.
  static DelimitedFraming lines(std::string start, std::size_t max_frame) {
    DelimitedFraming framing;
    framing.start = std::move(start);
    framing.end = '\n';
    framing.restart_on_start = true;
    framing.max_frame = max_frame;
    return framing;
  }
};

/// The framer of a `DelimitedFraming`.
class DelimitedFramer final : public CaptureFramer {
 public:
  /// A framer of `framing` (`max_frame` at least 1).
  explicit DelimitedFramer(DelimitedFraming framing);
  void feed(std::span<const std::uint8_t> bytes, const PacketSink& sink) override;
  void flush(std::string_view reason, const PacketSink& sink) override;

 private:
  enum class State { idle, leading, frame, skipping };
  bool starts(std::uint8_t byte) const;
  void emit_unframed(const PacketSink& sink);
  void add_unframed(std::uint8_t byte, const std::string& reason, const PacketSink& sink);

  DelimitedFraming framing_;
  State state_ = State::idle;
  std::vector<std::uint8_t> frame_;     // the frame being built (leading end bytes included)
  std::vector<std::uint8_t> unframed_;  // the unframed run being built
  std::string unframed_reason_;
};

/// A framing without frames: every read or write is one packet marked `unframed: no framing` (a registered
/// codec whose row gives no framing).
class ChunkFramer final : public CaptureFramer {
 public:
  void feed(std::span<const std::uint8_t> bytes, const PacketSink& sink) override;
  void flush(std::string_view, const PacketSink&) override {}
};

}  // namespace tether::transports
