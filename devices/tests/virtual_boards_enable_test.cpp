// Virtual boards are an explicit choice of the program: linking Tether::virtual_uno (this test executable
// does) is not enough, enable_virtual_boards() is. No image is needed: a missing one is the simulator's own
// error, which only an enabled program reaches.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <string>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/devices/virtual_boards.hpp"

namespace tether::devices {
namespace {

// The ConfigError opening device 0's transport throws (fails the test if it opens).
ConfigError transport_error(const RoverConfig& config) {
  boost::asio::io_context io;  // never run: both errors come before any I/O
  try {
    (void)open_transport(config.devices.at(0), io.get_executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    return error;
  }
  return ConfigError("", "");
}

TEST(VirtualBoardsEnable, LinkingTheLibraryIsNotEnoughTheCallIs) {
  ParseOptions options;
  options.firmware_dir = "/nonexistent/tether-firmware";
  const RoverConfig config = parse_config(
      R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"virtual": {"firmware": "romi-test"}}}]})",
      options);

  const ConfigError before = transport_error(config);
  EXPECT_EQ(before.code(), make_error_code(DevicesError::not_supported));
  EXPECT_EQ(before.path(), "transport.virtual");
  EXPECT_NE(std::string(before.what()).find("call tether::devices::enable_virtual_boards()"), std::string::npos)
      << before.what();

  enable_virtual_boards();
  enable_virtual_boards();  // idempotent
  const ConfigError after = transport_error(config);
  EXPECT_NE(after.code(), make_error_code(DevicesError::not_supported)) << after.what();
  EXPECT_EQ(after.path(), "transport.virtual.firmware") << after.what();
  EXPECT_NE(std::string(after.what()).find("/nonexistent/tether-firmware/romi-test"), std::string::npos)
      << after.what();
}

}  // namespace
}  // namespace tether::devices
