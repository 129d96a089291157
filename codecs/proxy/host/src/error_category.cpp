#include "tether/proxy/error_category.hpp"

#include <string>

namespace tether::proxy {
namespace {

class ProxyCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.proxy"; }
  std::string message(int value) const override {
    switch (static_cast<ProxyError>(value)) {
      case ProxyError::timed_out: return "no ack within the send budget";
      case ProxyError::refused: return "the device refused the message (it did not act on it)";
      case ProxyError::queue_timeout: return "waited too long before the first send";
      case ProxyError::device_reset: return "the device restarted while the message was in flight";
      case ProxyError::wrong_mode: return "not available in this client mode";
      case ProxyError::invalid_message: return "the message carries no data";
      case ProxyError::reserved_message: return "Reset is sent by the session handshake (use restart_session)";
      case ProxyError::message_too_large: return "message too large";
      case ProxyError::too_many_inits: return "too many registered inits";
    }
    return "unknown tether.proxy error";
  }
  boost::system::error_condition default_error_condition(int value) const noexcept override {
    const auto error = static_cast<ProxyError>(value);
    if (error == ProxyError::timed_out || error == ProxyError::queue_timeout) {
      return boost::system::errc::make_error_condition(boost::system::errc::timed_out);
    }
    return boost::system::error_condition(value, *this);
  }
};

}  // namespace

const boost::system::error_category& proxy_category() {
  static const ProxyCategory category;
  return category;
}

boost::system::error_code make_error_code(ProxyError error) {
  return boost::system::error_code(static_cast<int>(error), proxy_category());
}

}  // namespace tether::proxy
