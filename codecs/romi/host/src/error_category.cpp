#include "tether/romi/error_category.hpp"

#include <string>

namespace tether::romi {
namespace {

class RomiCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.romi"; }
  std::string message(int value) const override { return romi::describe(static_cast<std::int16_t>(value)); }
  boost::system::error_condition default_error_condition(int value) const noexcept override {
    if (value == static_cast<int>(Error::client_timeout)) {
      return boost::system::errc::make_error_condition(boost::system::errc::timed_out);
    }
    return boost::system::error_condition(value, *this);
  }
};

}  // namespace

const boost::system::error_category& romi_category() {
  static const RomiCategory category;
  return category;
}

boost::system::error_code make_error_code(Error code) {
  return boost::system::error_code(static_cast<int>(code), romi_category());
}

boost::system::error_code make_romi_error_code(std::int16_t code) {
  if (code == 0) return boost::system::error_code();
  return boost::system::error_code(code, romi_category());
}

}  // namespace tether::romi
