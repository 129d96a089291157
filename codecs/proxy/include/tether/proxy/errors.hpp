/// @file errors.hpp
/// Why the proxy decoder dropped a frame. Every drop is also counted by cause in `LinkCounters`
/// (oversize_frames, framing_errors, crc_errors); undecodable protobuf is the layer above's to count.
#pragma once

#include <stdint.h>

namespace tether {
namespace proxy {

/// A dropped frame's cause (the decoders' `error()`). Named `FrameError`, not `Error` like the other
/// codecs' enums, because `tether.proxy.Error` is the protocol's device-error message (tether_proxy.proto),
/// whose generated C++ class is `tether::proxy::Error` on the host.
enum class FrameError : uint8_t {
  none = 0,        ///< No frame was dropped.
  frame_too_long,  ///< More bytes than the decoder holds; it skips to the next 0x00.
  framing_error,   ///< Invalid COBS (the frame ended inside a block), or a frame too short for its CRC.
  crc_mismatch,    ///< The CRC-16 in front of the payload does not match it.
};

/// Short English text of `error` (the words `tether monitor` prints); never null.
const char* describe(FrameError error);

}  // namespace proxy
}  // namespace tether
