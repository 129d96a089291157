/// @file status.hpp
/// What a method handler returns: `Status::ok()`, or `Status::error(code, "text")` with a code in
/// 1..0xFEFF (errors.hpp keeps 0xFF00 and up for Tether's own), which reaches the caller as the call's
/// error (a C++ `error_code` and text, a Python `RpcError`, `tether call`'s exit status 1).
#pragma once

#include <stdint.h>

namespace tether {
namespace rpc {

/// A handler's outcome. The text is not copied until the reply is sent: a string literal, or text that
/// lives until the handler's caller has sent it (a static buffer).
class Status {
 public:
  /// Success: the reply (or stream message) the handler filled in is sent.
  static constexpr Status ok() { return Status(0, nullptr); }
  /// Failure with `code` (1..0xFEFF; others are sent as 0xFEFF) and a short `text` (at most 47
  /// characters reach the host).
  static constexpr Status error(uint16_t code, const char* text) {
    return Status(code == 0 || code > 0xFEFF ? 0xFEFF : code, text);
  }
  /// As `error`, with a text kept in flash on the AVR (a `const char[]` declared `PROGMEM`): no RAM for it.
  static constexpr Status error_P(uint16_t code, const char* text_in_flash) {
    return Status(code == 0 || code > 0xFEFF ? 0xFEFF : code, text_in_flash, true);
  }
  /// True for `ok()`.
  constexpr bool is_ok() const { return code_ == 0; }
  /// 0 for `ok()`.
  constexpr uint16_t code() const { return code_; }
  /// The error's text (null for `ok()`).
  constexpr const char* text() const { return text_; }
  /// True when `text()` is in flash (`error_P`).
  constexpr bool text_in_flash() const { return in_flash_; }

 private:
  constexpr Status(uint16_t code, const char* text, bool in_flash = false)
      : code_(code), text_(text), in_flash_(in_flash) {}
  uint16_t code_;
  const char* text_;
  bool in_flash_;
};

}  // namespace rpc
}  // namespace tether
