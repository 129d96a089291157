#include "tether/elcano/error_category.hpp"

#include <string>

namespace tether::elcano {
namespace {

class RingCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.elcano"; }
  std::string message(int value) const override {
    switch (static_cast<RingError>(value)) {
      case RingError::timed_out: return "no reply of the awaited type within the call budget";
      case RingError::undeliverable: return "the message came back round the ring: no node captured it";
      case RingError::reply_type_busy: return "a request awaiting this reply type is already in flight";
      case RingError::send_queue_full: return "the ring node's output queue and the client's send queue are full";
      case RingError::send_timed_out:
        return "not written in time: no room in the ring node's output queue, or the link took no bytes "
               "(a device that stopped reading)";
      case RingError::receive_timed_out: return "no captured message within the receive timeout";
      case RingError::invalid_message: return "the message lacks a field its type requires (or has no valid type)";
      case RingError::invalid_reply_type: return "the reply type is not D, S, G or X";
    }
    return "unknown tether.elcano error";
  }
  boost::system::error_condition default_error_condition(int value) const noexcept override {
    switch (static_cast<RingError>(value)) {
      case RingError::timed_out:
      case RingError::send_timed_out:
      case RingError::receive_timed_out:
        return boost::system::errc::make_error_condition(boost::system::errc::timed_out);
      case RingError::reply_type_busy:
      case RingError::send_queue_full:
        return boost::system::errc::make_error_condition(boost::system::errc::device_or_resource_busy);
      case RingError::invalid_message:
      case RingError::invalid_reply_type:
        return boost::system::errc::make_error_condition(boost::system::errc::invalid_argument);
      case RingError::undeliverable:
        break;
    }
    return boost::system::error_condition(value, *this);
  }
};

}  // namespace

const boost::system::error_category& ring_category() {
  static const RingCategory category;
  return category;
}

boost::system::error_code make_error_code(RingError error) {
  return boost::system::error_code(static_cast<int>(error), ring_category());
}

}  // namespace tether::elcano
