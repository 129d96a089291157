#include "tether/rpc/error_category.hpp"

#include <string>

namespace tether::rpc {
namespace {

class RpcCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.rpc"; }
  std::string message(int value) const override {
    switch (static_cast<RpcError>(value)) {
      case RpcError::device_error: return "the device answered with an error";
      case RpcError::refused: return "the device refused the message";
      case RpcError::schema_mismatch: return "the device was built from another schema";
      case RpcError::unknown_method: return "no such method in the schema";
      case RpcError::wrong_kind: return "a call to a streaming method, or a stream of a unary one";
      case RpcError::invalid_request: return "the request is not the method's input";
      case RpcError::request_too_large: return "request too large";
      case RpcError::timed_out: return "no answer within the call budget";
      case RpcError::queue_timeout: return "waited too long before the first send";
      case RpcError::device_reset: return "the device restarted while the call was in flight";
      case RpcError::bad_reply: return "the device's reply is not the method's output";
    }
    return "unknown tether.rpc error";
  }
  boost::system::error_condition default_error_condition(int value) const noexcept override {
    const auto error = static_cast<RpcError>(value);
    if (error == RpcError::timed_out || error == RpcError::queue_timeout) {
      return boost::system::errc::make_error_condition(boost::system::errc::timed_out);
    }
    return boost::system::error_condition(value, *this);
  }
};

}  // namespace

const boost::system::error_category& rpc_category() {
  static const RpcCategory category;
  return category;
}

boost::system::error_code make_error_code(RpcError error) {
  return boost::system::error_code(static_cast<int>(error), rpc_category());
}

}  // namespace tether::rpc
