#include "tether/transports/transport_error.hpp"

#include <map>
#include <memory>
#include <mutex>
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
      case TransportError::no_matching_port: return "no serial port matches the identity";
      case TransportError::several_matching_ports: return "several serial ports match the identity";
      case TransportError::disconnected: return "disconnected";
      case TransportError::reconnected: return "reconnected";
      case TransportError::reconnect_limit: return "the port did not come back (reconnect limit reached)";
    }
    return "unknown transport error";
  }
};

// A boost category that speaks for a std category.
class StdCategoryAdapter final : public boost::system::error_category {
 public:
  explicit StdCategoryAdapter(const std::error_category& inner) : inner_(&inner) {}
  const char* name() const noexcept override { return inner_->name(); }
  std::string message(int value) const override { return inner_->message(value); }

 private:
  const std::error_category* inner_;
};

}  // namespace

boost::system::error_code to_boost_error(const std::error_code& error) {
  if (!error) return {};
  if (error.category() == std::system_category()) return {error.value(), boost::system::system_category()};
  if (error.category() == std::generic_category()) return {error.value(), boost::system::generic_category()};
  // Categories are singletons that live as long as the program: one adapter each, never freed.
  static std::mutex mutex;
  static std::map<const std::error_category*, std::unique_ptr<StdCategoryAdapter>> adapters;
  std::lock_guard lock(mutex);
  auto& adapter = adapters[&error.category()];
  if (!adapter) adapter = std::make_unique<StdCategoryAdapter>(error.category());
  return {error.value(), *adapter};
}

const boost::system::error_category& transport_category() {
  static const TransportCategory category;
  return category;
}

boost::system::error_code make_error_code(TransportError error) {
  return {static_cast<int>(error), transport_category()};
}

}  // namespace tether::transports
