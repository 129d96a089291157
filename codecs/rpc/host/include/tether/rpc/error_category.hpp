/// @file error_category.hpp
/// Failures of the rpc host client as `boost::system::error_code`s: the "tether.rpc" category.
///
/// `RpcError` is registered as an error-code enum, so it compares equal to an `error_code` of this category
/// (`if (error == tether::rpc::RpcError::device_error) ...`). A device's own error comes as `device_error`
/// (the application's code and text in the result: `CallResult::device_error`), a refusal by Tether's
/// device runtime as `refused` (its code, from 0xFF00, and text likewise). `timed_out` and `queue_timeout`
/// map to the generic condition `errc::timed_out`. Failures that are not the protocol's (closed, the link
/// failed) arrive as asio / transport error codes: `operation_aborted`, `eof`, `broken_pipe`, ...
#pragma once

#include <boost/system/error_code.hpp>

#include <type_traits>

namespace tether::rpc {

/// Why a call or stream failed, when the reason is the rpc protocol's (values are stable).
enum class RpcError {
  device_error = 1,   ///< The device's handler answered `Status::error(code, text)`.
  refused,            ///< Tether's device runtime refused it (unknown method, bad request, period too short, ...).
  schema_mismatch,    ///< The device was built from another schema (its hash differs from this client's).
  unknown_method,     ///< The schema has no such method.
  wrong_kind,         ///< A call to a streaming method, or a stream of a unary one.
  invalid_request,    ///< The request is not of the method's input type, or its JSON does not parse.
  request_too_large,  ///< The encoded request exceeds `kMaxRequestBytes`.
  timed_out,          ///< No answer within the call budget, every re-send included.
  queue_timeout,      ///< Waited `queue_timeout` before its first send (no session yet, 8 in flight).
  device_reset,       ///< The device restarted while the call was in flight: it may or may not have run.
  bad_reply,          ///< The device's reply does not decode as the method's output type.
};

/// The "tether.rpc" category.
const boost::system::error_category& rpc_category();

/// An error_code of the "tether.rpc" category.
boost::system::error_code make_error_code(RpcError error);

}  // namespace tether::rpc

/// Registers `rpc::RpcError` as an error-code enum (implicit conversion and comparison).
template <>
struct boost::system::is_error_code_enum<tether::rpc::RpcError> : std::true_type {};
