// The devices library's error category and ConfigError (config.hpp).
#include <string>
#include <utility>

#include "tether/devices/config.hpp"

namespace tether::devices {

namespace {

class DevicesCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.devices"; }
  std::string message(int value) const override {
    switch (static_cast<DevicesError>(value)) {
      case DevicesError::invalid_config: return "invalid configuration";
      case DevicesError::unknown_device: return "no device of that name";
      case DevicesError::wrong_codec: return "the device speaks another codec";
      case DevicesError::not_supported: return "not supported by this build";
      case DevicesError::device_not_ready: return "the device did not answer its handshake in time";
    }
    return "unknown tether.devices error";
  }
};

std::string compose(const std::string& file, const std::string& path, const std::string& detail) {
  std::string text;
  if (!file.empty()) text += file + ": ";
  if (!path.empty()) text += path + ": ";
  return text + detail;
}

}  // namespace

const boost::system::error_category& devices_category() {
  static const DevicesCategory category;
  return category;
}

error_code make_error_code(DevicesError error) { return error_code(static_cast<int>(error), devices_category()); }

ConfigError::ConfigError(std::string path, std::string detail, error_code code, std::string file)
    : std::runtime_error(compose(file, path, detail)),
      path_(std::move(path)),
      detail_(std::move(detail)),
      code_(code),
      file_(std::move(file)) {}

}  // namespace tether::devices
