/// @file encoder.hpp
/// The proxy protocol's frame and its writer: `COBS(crc16 ‖ payload) ‖ 0x00`, payload = one protobuf
/// message.
///
/// - crc16 is CRC-16/MCRF4XX of the payload (core/crc.hpp), little-endian, IN FRONT of the payload (the
///   design's stack picture: CRC, then framing). Worked example: payload `0a 06 08 9f 0e 10 cf 09` has
///   crc 0x8857 and goes on the wire as `0b 57 88 0a 06 08 9f 0e 10 cf 09 00`.
/// - Senders may write a 0x00 before a frame to flush line garbage; receivers ignore empty frames.
/// - Compatibility mode (the deployed variant): no CRC; host to device `0x00 ‖ COBS(pb) ‖ 0x00`, device to
///   host `COBS(pb) ‖ 0x00`.
/// The reader of these frames is decoder.hpp.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/status.hpp"
#include "tether/proxy/cobs.hpp"

namespace tether {
namespace proxy {

/// Primary mode (CRC) or the deployed variant (none).
enum class Integrity : uint8_t {
  crc16,  ///< CRC-16/MCRF4XX in front of the payload.
  none,   ///< Compatibility mode: the deployed firmware has no CRC.
};

/// Bytes a frame of `payload_size` takes on the wire at most (leading and trailing delimiters included).
constexpr size_t max_frame_size(size_t payload_size) { return cobs_max_encoded_size(payload_size + 2) + 2; }

/// Writes the frame of `payload` into `out`: an optional leading 0x00, COBS(crc ‖ payload), 0x00. One
/// pass over the payload (COBS and CRC in the same loop); `payload` and `out` must not overlap.
/// `Status::buffer_too_small` when `out` is shorter than the worst case (`max_frame_size` covers it).
Result<size_t> encode_frame(ByteView payload, Integrity integrity, bool leading_delimiter, MutableByteView out);

}  // namespace proxy
}  // namespace tether
