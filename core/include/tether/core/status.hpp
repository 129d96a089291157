/// @file status.hpp
/// The error vocabulary of the portable layer: one enum returned by value, plus a small result type.
///
/// Portable code never throws; every fallible operation returns a `Status` or a `Result<T>`. Codecs keep
/// their own wire error codes (Romi's -1..-28, for example) and map them onto `Status` only where a
/// protocol-neutral caller needs to branch. `to_string` gives a short, stable English message.
#pragma once

#include <stdint.h>

namespace tether {

/// Outcome of a portable operation. Values are stable: they are logged and counted.
enum class Status : uint8_t {
  ok = 0,             ///< Success.
  busy,               ///< No free slot (request table full, buffer in use).
  buffer_too_small,   ///< Output buffer cannot hold the result.
  frame_too_long,     ///< Incoming frame exceeds the configured maximum.
  crc_mismatch,       ///< Checksum does not match the frame contents.
  framing_error,      ///< Bytes do not form a frame of the protocol.
  invalid_argument,   ///< Caller passed a value outside the contract.
  not_found,          ///< No entry for the given key (e.g. a reply id not in flight).
  remote_error,       ///< The peer answered with a non-success code.
};

/// Short English description of `status`; never null.
const char* to_string(Status status);

/// A value or the reason there is none. `T` must be default-constructible and copyable (AVR-friendly:
/// no placement new, no exceptions).
template <typename T>
class Result {
 public:
  /// Successful result holding `value`.
  Result(const T& value) : value_(value), status_(Status::ok) {}  // NOLINT: implicit on purpose
  /// Failed result; `status` must not be `Status::ok`.
  Result(Status status) : value_(), status_(status) {}  // NOLINT: implicit on purpose

  /// True when a value is present.
  bool ok() const { return status_ == Status::ok; }
  /// Why there is no value (`Status::ok` when there is one).
  Status status() const { return status_; }
  /// The value; meaningful only when `ok()`.
  const T& value() const { return value_; }

 private:
  T value_;
  Status status_;
};

}  // namespace tether
