/// @file boot_frame.hpp
/// How a host recognises that an image of a COBS codec (proxy, rpc) has booted: at the end of its setup the
/// image sends 0x00 and then a whole frame (its `ResetEvent`), so the bytes a bootloader or a half-started
/// board may print before it are told apart from the announcement. Portable and header-only.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {
namespace proxy {

/// Fewest bytes of an encoded frame between its two 0x00 delimiters: the COBS code byte and the CRC-16
/// (fewer is line noise, not a frame).
constexpr size_t kBootFrameMinBytes = 3;

/// Looks for the announcement in `size` bytes read since the port opened: the first 0x00 followed by at
/// least `kBootFrameMinBytes` non-zero bytes and another 0x00. Returns true and sets `start` to the offset of
/// that first 0x00 (what follows it is the frame, for the client); false while no such frame is complete.
inline bool find_boot_frame(const uint8_t* data, size_t size, size_t& start) {
  size_t opened = size;  // offset of the last 0x00 seen, `size` while none
  for (size_t at = 0; at < size; ++at) {
    if (data[at] != 0) continue;
    if (opened != size && at - opened > kBootFrameMinBytes) {
      start = opened;
      return true;
    }
    opened = at;
  }
  return false;
}

}  // namespace proxy
}  // namespace tether
