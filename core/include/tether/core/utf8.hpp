/// @file utf8.hpp
/// Where well-formed UTF-8 starts and ends in bytes a device sent: the host shows device text to people
/// (escaping what is not UTF-8) and repairs protobuf strings that are not, with this one definition.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {

/// The length (1..4) of the well-formed UTF-8 sequence at `data[at]` (RFC 3629: no overlong forms, no
/// surrogates, nothing above U+10FFFF), or 0 when none starts there. `at < size`.
inline uint8_t utf8_sequence_length(const uint8_t* data, size_t size, size_t at) {
  const auto byte = [&](size_t i) -> unsigned { return i < size ? data[i] : 0u; };
  const auto continuation = [&](size_t i) { return (byte(i) & 0xC0u) == 0x80u; };
  const unsigned lead = byte(at);
  if (lead < 0x80) return 1;
  if (lead >= 0xC2 && lead <= 0xDF) return continuation(at + 1) ? 2 : 0;
  if (lead >= 0xE0 && lead <= 0xEF) {
    if (!continuation(at + 1) || !continuation(at + 2)) return 0;
    if (lead == 0xE0 && byte(at + 1) < 0xA0) return 0;   // overlong
    if (lead == 0xED && byte(at + 1) >= 0xA0) return 0;  // surrogate
    return 3;
  }
  if (lead >= 0xF0 && lead <= 0xF4) {
    if (!continuation(at + 1) || !continuation(at + 2) || !continuation(at + 3)) return 0;
    if (lead == 0xF0 && byte(at + 1) < 0x90) return 0;   // overlong
    if (lead == 0xF4 && byte(at + 1) >= 0x90) return 0;  // above U+10FFFF
    return 4;
  }
  return 0;
}

}  // namespace tether
