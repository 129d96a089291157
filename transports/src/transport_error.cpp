#include "tether/transports/transport_error.hpp"

#include <string>

namespace tether::transports {
namespace {

class TransportCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.transport"; }
  std::string message(int value) const override {
    switch (static_cast<TransportError>(value)) {
      case TransportError::timed_out: return "operation timed out";
      case TransportError::closed: return "stream closed";
      case TransportError::read_in_progress: return "a read is already in progress on this stream";
      case TransportError::would_deadlock: return "blocking call on the stream's own executor would deadlock";
      case TransportError::boot_timeout: return "device did not finish booting after the port opened";
      case TransportError::invalid_option: return "invalid transport option";
      case TransportError::simulator_stopped: return "virtual Uno stopped";
    }
    return "unknown transport error";
  }
};

}  // namespace

const boost::system::error_category& transport_category() {
  static const TransportCategory category;
  return category;
}

boost::system::error_code make_error_code(TransportError error) {
  return {static_cast<int>(error), transport_category()};
}

}  // namespace tether::transports
