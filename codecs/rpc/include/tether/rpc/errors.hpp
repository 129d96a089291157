/// @file errors.hpp
/// The codes of a DeviceError (tether_rpc.proto): what a call or stream answered instead of its reply.
///
/// Codes 1..0xFEFF are the application's: a handler's `Status::error(code, text)` (device/status.hpp).
/// Codes from 0xFF00 are Tether's own, sent by the device runtime before or instead of a handler; their
/// texts name what was wrong. 0 is never an error.
#pragma once

#include <stdint.h>

namespace tether {
namespace rpc {

/// Tether's own DeviceError codes.
enum class DeviceErrorCode : uint16_t {
  unknown_method = 0xFF01,      ///< No method has that index (a host built from another schema).
  bad_request = 0xFF02,         ///< The request does not decode as the method's input (or exceeds its bounds).
  not_unary = 0xFF03,           ///< A Call to a streaming method.
  not_streaming = 0xFF04,       ///< An OpenStream of a unary method.
  period_too_short = 0xFF05,    ///< A stream period below the device's minimum (one frame time at its baud).
  request_too_large = 0xFF06,   ///< A stream's request longer than the device keeps for it.
  reply_too_large = 0xFF07,     ///< The handler's reply (or stream message) does not fit a frame.
  bad_envelope = 0xFF08,        ///< A checked frame whose payload is not a HostMessage.
  unknown_message = 0xFF09,     ///< A HostMessage with no body the device knows (a newer host).
  streams_full = 0xFF0A,        ///< An OpenStream while every stream slot serves another method.
};

/// Largest code a handler may use.
constexpr uint16_t kMaxApplicationCode = 0xFEFF;

}  // namespace rpc
}  // namespace tether
