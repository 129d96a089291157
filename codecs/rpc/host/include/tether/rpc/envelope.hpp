/// @file envelope.hpp
/// The rpc envelope (tether_rpc.proto: HostMessage, DeviceMessage) written and read by hand on the host:
/// what the client puts around each request and takes off each device answer, without libprotobuf's
/// classes (no allocation, no lock, views into the frame instead of copies). The wire format is the
/// .proto's; these functions only replace libprotobuf's code for it:
///   - `encode` writes exactly libprotobuf's serialization of the same HostMessage (fields in number
///     order, proto3 zeros and empty bytes omitted, the oneof's message written even when empty);
///   - `decode` accepts exactly what libprotobuf's parser accepts as a DeviceMessage (any field order,
///     unknown fields of every wire type, groups included; a repeated scalar: the last one wins; a
///     repeated oneof message: merged; another oneof member: replaces) and refuses the rest with a
///     reason (`DecodeError`).
/// `FrameReader` takes the device's frames off the link: proxy::Decoder's frames, errors and counters,
/// with a frame that arrived whole decoded in one pass.
/// A DeviceError's text is handed over as the device sent it; `device_text` makes it what
/// proxy::parse_device_message keeps of it (libprotobuf refuses a proto3 string that is not UTF-8).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/errors.hpp"

namespace tether::rpc::envelope {

/// Which body a HostMessage carries (its oneof; the values are the field numbers).
enum class HostBody : std::uint8_t {
  none = 0,   ///< No body (never sent by the client; libprotobuf writes only the id).
  hello = 2,  ///< Hello.
  call = 3,   ///< Call{method, request}.
  open = 4,   ///< OpenStream{method, request, period_ms}.
  close = 5,  ///< CloseStream{stream}.
  ping = 6,   ///< Ping.
  reset = 7,  ///< Reset.
};

/// A HostMessage to write. Only the fields of `body` are written.
struct HostMessage {
  std::uint32_t id = 0;            ///< The message id.
  HostBody body = HostBody::none;  ///< The oneof.
  std::uint32_t method = 0;        ///< call, open: the method's index.
  ByteView request;                ///< call, open: the encoded request (must outlive the encoding).
  std::uint32_t period_ms = 0;     ///< open.
  std::uint32_t stream = 0;        ///< close.
};

/// Bytes `encode` writes for `message`.
std::size_t encoded_size(const HostMessage& message);
/// Writes `message` at `out` (room for `encoded_size(message)` bytes); returns the bytes written.
std::size_t encode(const HostMessage& message, std::uint8_t* out);
/// `message` as a proxy frame (COBS(crc16 ‖ message) ‖ 0x00, after a leading 0x00) in `frame`, replaced
/// (its capacity is reused: a recycled frame string allocates nothing).
void write_frame(const HostMessage& message, std::string& frame);

/// What `read_whole_frame` found in one complete COBS frame.
enum class WholeFrame : std::uint8_t {
  frame,         ///< A payload whose CRC-16 matched.
  too_long,      ///< More decoded bytes than the buffer holds.
  bad_cobs,      ///< The frame ended inside a block.
  too_short,     ///< Fewer than the CRC's two bytes.
  crc_mismatch,  ///< The CRC-16 in front of the payload does not match it.
};
/// Decodes the COBS frame `encoded` (the bytes between two delimiters: no 0x00, at least one byte) into
/// `out` (room for `capacity` bytes) and checks its CRC-16/MCRF4XX; on `frame`, `size` is the decoded
/// size (the CRC's two bytes, then the payload). proxy::Decoder's verdict on the same bytes.
WholeFrame read_whole_frame(ByteView encoded, std::uint8_t* out, std::size_t capacity, std::size_t& size);

/// The device's frames out of the bytes the link delivers: the same frames, errors and LinkCounters as
/// proxy::Decoder<MaxPayload> in crc16 mode (which it holds), but a frame that arrives whole in one read
/// is decoded in one pass (its blocks copied, its CRC computed eight bytes per step, `read_whole_frame`)
/// instead of byte by byte with the CRC's per-byte chain. Bytes of a frame split across reads, and any
/// bytes after an overlong frame until its delimiter, go through proxy::Decoder.
template <std::size_t MaxPayload>
class FrameReader {
 public:
  /// Reader counting into `counters` (frames_ok, crc_errors, framing_errors, oversize_frames, resyncs);
  /// `counters` outlives it.
  explicit FrameReader(LinkCounters& counters) : counters_(counters), decoder_(proxy::Integrity::crc16, counters) {}
  /// Consumes `bytes` up to and including the first one that completes a frame or an error, as
  /// proxy::Decoder::feed (a frame too long is reported once its delimiter is in `bytes`, when it arrived
  /// whole).
  FeedResult feed(ByteView bytes) {
    if (idle_ && !bytes.empty()) {
      const void* zero = std::memchr(bytes.data(), 0, bytes.size());
      if (zero != nullptr) return feed_whole(bytes, static_cast<const std::uint8_t*>(zero));
    }
    const FeedResult fed = decoder_.feed(bytes);
    from_decoder_ = true;
    if (fed.status == DecodeStatus::more) {
      // Idle again only after a delimiter (a resync's end or one between frames): the decoder's state
      // is then the fresh one.
      idle_ = fed.consumed != 0 && bytes[fed.consumed - 1] == 0x00;
    } else {
      idle_ = fed.status == DecodeStatus::frame || decoder_.error() != proxy::FrameError::frame_too_long;
    }
    return fed;
  }
  /// After `frame`: the checked payload (valid until the next feed).
  ByteView frame() const {
    if (from_decoder_) return decoder_.frame();
    return ByteView(buffer_.data() + 2, size_ - 2);
  }
  /// After `error`: why the frame was dropped.
  proxy::FrameError error() const { return from_decoder_ ? decoder_.error() : error_; }

 private:
  // The frame from the reader's position to `zero`, its delimiter, whole (the decoder is between frames).
  FeedResult feed_whole(ByteView bytes, const std::uint8_t* zero) {
    from_decoder_ = false;
    const auto consumed = static_cast<std::size_t>(zero - bytes.data()) + 1;
    if (consumed == 1) return FeedResult{DecodeStatus::more, 1};  // a delimiter between frames
    const ByteView encoded(bytes.data(), consumed - 1);
    switch (read_whole_frame(encoded, buffer_.data(), buffer_.size(), size_)) {
      case WholeFrame::frame:
        add_one(counters_.frames_ok);
        return FeedResult{DecodeStatus::frame, consumed};
      case WholeFrame::too_long:  // the decoder drops it where it overflows, then resyncs at the delimiter
        add_one(counters_.oversize_frames);
        add_one(counters_.resyncs);
        return fail(proxy::FrameError::frame_too_long, consumed);
      case WholeFrame::bad_cobs:
      case WholeFrame::too_short:
        add_one(counters_.framing_errors);
        return fail(proxy::FrameError::framing_error, consumed);
      case WholeFrame::crc_mismatch:
        add_one(counters_.crc_errors);
        return fail(proxy::FrameError::crc_mismatch, consumed);
    }
    return FeedResult{DecodeStatus::more, consumed};
  }
  FeedResult fail(proxy::FrameError error, std::size_t consumed) {
    error_ = error;
    return FeedResult{DecodeStatus::error, consumed};
  }

  LinkCounters& counters_;
  proxy::Decoder<MaxPayload> decoder_;
  bool idle_ = true;           // the decoder is between frames: the next frame may be read whole
  bool from_decoder_ = false;  // the last event was the decoder's
  proxy::FrameError error_ = proxy::FrameError::none;
  std::size_t size_ = 0;
  std::array<std::uint8_t, MaxPayload + 2> buffer_{};
};

/// Which body a DeviceMessage carries (its oneof; the values are the field numbers).
enum class DeviceBody : std::uint8_t {
  none = 0,    ///< No body (a valid, empty message).
  ack = 1,     ///< `ack`.
  reply = 2,   ///< `reply`.
  error = 3,   ///< `error`.
  stream = 4,  ///< `stream`.
  hello = 5,   ///< `hello`.
  reset = 6,   ///< `reset`.
};

/// A decoded DeviceMessage: the fields of `body`'s message (the others are zero). Byte fields are views
/// into the decoded payload (valid as long as it is).
struct DeviceMessage {
  DeviceBody body = DeviceBody::none;  ///< The oneof.
  /// Ack.
  struct Ack {
    std::uint32_t id = 0;   ///< The message acknowledged.
    bool refused = false;   ///< The device did not act on it.
  } ack;
  /// Reply.
  struct Reply {
    std::uint32_t call = 0;  ///< The call answered.
    ByteView reply;          ///< The reply, encoded with the method's output type.
  } reply;
  /// DeviceError.
  struct Error {
    std::uint32_t call = 0;  ///< The call or stream that failed.
    std::uint32_t code = 0;  ///< Its code.
    ByteView text;           ///< Its text as sent (see `text_is_utf8`).
  } error;
  /// StreamMessage.
  struct Stream {
    std::uint32_t stream = 0;  ///< The stream (its OpenStream's message id).
    std::uint32_t seq = 0;     ///< Its number in the stream.
    ByteView message;          ///< The message, encoded with the method's output type.
  } stream;
  /// DeviceHello.
  struct Hello {
    std::uint64_t schema_hash = 0;  ///< The device's schema hash.
    std::uint32_t session = 0;      ///< Its session.
    std::uint32_t max_payload = 0;  ///< The largest payload it accepts.
    std::uint32_t methods = 0;      ///< Its methods.
  } hello;
  /// ResetEvent.
  struct Reset {
    std::uint32_t session = 0;  ///< The new session.
  } reset;
};

/// Why `decode` refused a payload (what libprotobuf refuses too).
enum class DecodeError : std::uint8_t {
  none = 0,          ///< Decoded.
  truncated,         ///< A field runs past the end of its message (or of the payload).
  bad_varint,        ///< A varint longer than 10 bytes (a tag or a length longer than 5).
  bad_tag,           ///< Field number 0, or wire type 6 or 7.
  bad_length,        ///< A length of 2 GiB or more.
  unexpected_end_group,  ///< An end-group tag outside its group (or of another field's group).
  unterminated_group,    ///< A group without its end-group tag.
  too_deep,          ///< Messages and groups nested more than 100 deep (libprotobuf's recursion limit).
};

/// A sentence for `error`: "a field runs past the end of its message", ...
const char* describe(DecodeError error);

/// Decodes `payload` as a DeviceMessage into `out` (reset first). `DecodeError::none` when libprotobuf
/// would parse it; the views in `out` then point into `payload`.
DecodeError decode(ByteView payload, DeviceMessage& out);

/// True when `text` is what libprotobuf accepts in a proto3 `string` field (structurally valid UTF-8).
bool text_is_utf8(ByteView text);

/// A DeviceError's text as proxy::parse_device_message keeps it: as it is when `text_is_utf8`, otherwise
/// with each byte that starts no well-formed UTF-8 sequence written as `\xNN` (lowercase hex).
std::string device_text(ByteView text);

}  // namespace tether::rpc::envelope
