/// @file error_category.hpp
/// Romi codes as `boost::system::error_code`s: the "tether.romi" category.
///
/// The category's values are the Romi wire codes themselves (negative for the protocol, positive for the
/// application; 0 is never an error) and its messages are `romi::describe(code)`, so
/// `make_error_code(Error::client_timeout).message()` is "client: no reply from the device" and
/// `error.value()` is -25. `romi::Error` is registered as an error-code enum, so an `Error`
/// compares equal to an `error_code` of this category:
/// @code
///   if (error == tether::romi::Error::client_timeout) { ... }
/// @endcode
/// The client timeout (-25) maps to the generic condition `errc::timed_out`, so portable code can test
/// `error == boost::system::errc::timed_out` without knowing the protocol.
#pragma once

#include <boost/system/error_code.hpp>

#include <cstdint>
#include <type_traits>

#include "tether/romi/errors.hpp"

namespace tether::romi {

/// The "tether.romi" category: values are Romi codes, messages `romi::describe(code)`.
const boost::system::error_category& romi_category();

/// An error_code of the "tether.romi" category for `code`.
boost::system::error_code make_error_code(Error code);

/// An error_code of the "tether.romi" category for a raw Romi code (0 gives a success error_code).
boost::system::error_code make_romi_error_code(std::int16_t code);

}  // namespace tether::romi

/// Registers `romi::Error` as an error-code enum (implicit conversion and comparison).
template <>
struct boost::system::is_error_code_enum<tether::romi::Error> : std::true_type {};
