/// @file limits.hpp
/// Sizes of the Romi protocol, with the reason for each.
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace tether {
namespace romi {

/// The spec: a whole request frame must fit the Uno's 64-byte serial buffer. Tether hosts never send more.
constexpr size_t kMaxRequestFrame = 64;
/// Frame bytes around the payload: '#', ':', two id and two CRC characters, "\r\n".
constexpr size_t kFrameOverhead = 8;
/// Longest payload (opcode + arguments) a Tether host sends: 64 - 8.
constexpr size_t kMaxHostPayload = kMaxRequestFrame - kFrameOverhead;
/// Longest payload Tether firmware accepts: 58, the reference client's limit, so every request a
/// reference host can produce is accepted (the reference firmware takes only 57: defect B1).
constexpr size_t kMaxDevicePayload = 58;
/// Integer arguments per request.
constexpr uint8_t kMaxArguments = 12;
/// Characters of the one string argument.
constexpr uint8_t kMaxStringLength = 32;
/// Decoder capacity a Tether host uses for responses and log lines: far above the reference's 57 (B2).
constexpr size_t kHostDecoderCapacity = 1024;
/// Decoder capacity of Tether firmware: the payload, ':' and four metadata characters.
constexpr size_t kDeviceDecoderCapacity = kMaxDevicePayload + 5;
/// The spec's deadlines: the controller answers within 1 s, a host call takes at most 2 s.
constexpr uint32_t kControllerDeadlineMs = 1000;
/// Total time of one host call (all attempts, log lines and stale frames included).
constexpr uint32_t kHostCallBudgetMs = 2000;

}  // namespace romi
}  // namespace tether
