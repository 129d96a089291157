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
/// A DeviceError's text is handed over as the device sent it; `device_text` makes it what
/// proxy::parse_device_message keeps of it (libprotobuf refuses a proto3 string that is not UTF-8).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "tether/core/bytes.hpp"

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
