/// @file error_category.hpp
/// Failures of the proxy host client as `boost::system::error_code`s: the "tether.proxy" category.
///
/// `ProxyError` is registered as an error-code enum, so it compares equal to an `error_code` of this
/// category:
/// @code
///   if (error == tether::proxy::ProxyError::device_reset) { ... }
/// @endcode
/// `timed_out` and `queue_timeout` map to the generic condition `errc::timed_out`, so portable code can test
/// `error == boost::system::errc::timed_out` without knowing the protocol. Failures that are not the
/// protocol's (the client was closed, the link failed) arrive as asio / transport error codes instead:
/// `asio::error::operation_aborted`, `asio::error::eof`, `broken_pipe`, ...
#pragma once

#include <boost/system/error_code.hpp>

#include <type_traits>

namespace tether::proxy {

/// Why a send failed, when the reason is the proxy protocol's (values are stable).
enum class ProxyError {
  timed_out = 1,      ///< Primary mode: no ack within the send budget, every re-send included.
  queue_timeout,      ///< Waited `queue_timeout` before its first send (no session yet, or its pin busy).
  device_reset,       ///< The device restarted (or was reset) while the message was in flight: it may or
                      ///< may not have run it. Registered inits are replayed by the client anyway.
  wrong_mode,         ///< A message of the other mode's schema, or an operation the mode does not have.
  invalid_message,    ///< The message carries no data (its oneof is not set).
  reserved_message,   ///< Primary mode: `Reset` belongs to the session handshake; use `restart_session()`.
  message_too_large,  ///< The encoded message exceeds `kMaxPayload` bytes.
  too_many_inits,     ///< `kMaxInits` different inits are registered already.
  refused,            ///< Primary mode: the device acked the message without acting on it (bad or
                      ///< uninitialised pin, e.g. just rebooted; its Error report says which).
};

/// The "tether.proxy" category.
const boost::system::error_category& proxy_category();

/// An error_code of the "tether.proxy" category.
boost::system::error_code make_error_code(ProxyError error);

}  // namespace tether::proxy

/// Registers `proxy::ProxyError` as an error-code enum (implicit conversion and comparison).
template <>
struct boost::system::is_error_code_enum<tether::proxy::ProxyError> : std::true_type {};
