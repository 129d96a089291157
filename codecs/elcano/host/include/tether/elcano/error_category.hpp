/// @file error_category.hpp
/// Failures of the Elcano host ring node (`elcano::RingClient`) as `boost::system::error_code`s: the
/// "tether.elcano" category.
///
/// `RingError` is registered as an error-code enum, so it compares equal to an `error_code` of this
/// category:
/// @code
///   if (error == tether::elcano::RingError::undeliverable) { ... }
/// @endcode
/// Generic conditions, for code that does not know the protocol: the three timeouts are
/// `errc::timed_out`, the two "busy" errors `errc::device_or_resource_busy`, the two rejected arguments
/// `errc::invalid_argument`. Failures that are not the ring's (the client was closed, the link failed)
/// arrive as asio / transport error codes instead: `asio::error::operation_aborted`, `asio::error::eof`,
/// `broken_pipe`, ...
#pragma once

#include <boost/system/error_code.hpp>

#include <type_traits>

namespace tether::elcano {

/// Why an operation of the ring client failed, when the reason is the ring's (values are stable).
enum class RingError {
  timed_out = 1,       ///< Request: no reply of the awaited type within the call budget (every re-send included).
  undeliverable,       ///< Request: it came back round the ring: no node captured its type.
  reply_type_busy,     ///< Request: a request awaiting the same reply type is already in flight.
  send_queue_full,     ///< Send or request: the node's output queue is full and so is the client's send queue.
  send_timed_out,      ///< Not written in time: a send within `send_timeout` (no room in the node's output
                       ///< queue, or the stream took no bytes), a request within its call budget.
  receive_timed_out,   ///< Receive: no captured message within the given timeout.
  invalid_message,     ///< The message lacks a field its type requires, or its type is not D, S, G or X.
  invalid_reply_type,  ///< Request: the reply type is not D, S, G or X.
};

/// The "tether.elcano" category.
const boost::system::error_category& ring_category();

/// An error_code of the "tether.elcano" category.
boost::system::error_code make_error_code(RingError error);

}  // namespace tether::elcano

/// Registers `elcano::RingError` as an error-code enum (implicit conversion and comparison).
template <>
struct boost::system::is_error_code_enum<tether::elcano::RingError> : std::true_type {};
