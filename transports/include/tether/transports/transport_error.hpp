/// @file transport_error.hpp
/// Error codes of the transports, as a `boost::system` error category ("tether.transport").
///
/// Operating-system and asio errors (ENOENT, EACCES, connection_refused, eof, operation_aborted, ...) are
/// passed through unchanged; these codes cover what the OS cannot say.
#pragma once

#include <boost/system/error_code.hpp>
#include <boost/system/system_error.hpp>

#include <future>
#include <system_error>
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
  no_matching_port,    ///< No serial port has the identity asked for (serial_ports.hpp).
  several_matching_ports,  ///< More than one serial port has the identity asked for.
  disconnected,        ///< The port vanished (unplugged); a supervised stream is waiting for it to return.
  reconnected,         ///< Not a failure: the notice that a supervised stream's port is back (a read, no bytes).
  reconnect_limit,     ///< A supervised stream gave up re-opening its port (its attempt limit was reached).
};

/// The "tether.transport" category.
const boost::system::error_category& transport_category();

/// Makes an error_code of the transport category.
boost::system::error_code make_error_code(TransportError error);

/// The same error as a boost error_code (Boost 1.74 converts only the other way): std's system and
/// generic categories map to boost's; any other category keeps its name and messages through an adapter.
boost::system::error_code to_boost_error(const std::error_code& error);

/// The value of a `use_future` operation, or a default value and its error in `error`: how the blocking
/// `error_code` overloads (`SerialPortStream::open`, `TcpStream::connect`) wait for their async version.
template <typename T>
T get_or_error(std::future<T>& future, boost::system::error_code& error) {
  try {
    error = boost::system::error_code();
    return future.get();
  } catch (const boost::system::system_error& failure) {
    error = failure.code();
    return T();
  }
}

}  // namespace tether::transports

template <>
struct boost::system::is_error_code_enum<tether::transports::TransportError> : std::true_type {};
