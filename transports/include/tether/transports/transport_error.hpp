/// @file transport_error.hpp
/// Error codes of the transports, as a `boost::system` error category ("tether.transport").
///
/// Operating-system and asio errors (ENOENT, EACCES, connection_refused, eof, operation_aborted, ...) are
/// passed through unchanged; these codes cover what the OS cannot say.
#pragma once

#include <boost/system/error_code.hpp>

#include <type_traits>

namespace tether::transports {

/// Transport failures with no OS error of their own.
enum class TransportError {
  timed_out = 1,       ///< The operation's deadline passed first.
  closed,              ///< The stream was closed (locally) before or during the operation.
  read_in_progress,    ///< A second read was started while one is pending (streams allow one reader).
  would_deadlock,      ///< A blocking call was made from the thread that must complete it.
  boot_timeout,        ///< The device did not finish booting in time after the port opened.
  invalid_option,      ///< An option value is out of range (baud, buffer size, ...).
  simulator_stopped,   ///< The virtual Uno behind the stream stopped.
};

/// The "tether.transport" category.
const boost::system::error_category& transport_category();

/// Makes an error_code of the transport category.
boost::system::error_code make_error_code(TransportError error);

}  // namespace tether::transports

template <>
struct boost::system::is_error_code_enum<tether::transports::TransportError> : std::true_type {};
