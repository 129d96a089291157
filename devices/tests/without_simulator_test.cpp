// A program that links Tether::devices without Tether::virtual_uno (this test executable) drives hardware
// only: it links no libsimavr, and a configuration's virtual boards are refused with the library they need,
// neither opened nor a link error.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <string>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"

namespace tether::devices {
namespace {

void expect_simulator_missing(const RoverConfig& config, std::size_t device, const std::string& path) {
  boost::asio::io_context io;  // never run: the refusal comes before any I/O
  try {
    (void)open_transport(config.devices.at(device), io.get_executor());
    ADD_FAILURE() << "opened " << path << " without the simulator";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.code(), make_error_code(DevicesError::not_supported));
    EXPECT_EQ(error.path(), path);
    EXPECT_NE(std::string(error.what()).find("link Tether::virtual_uno"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("call tether::devices::enable_virtual_boards()"), std::string::npos)
        << error.what();
  }
}

TEST(DevicesWithoutSimulator, VirtualBoardNamesTheLibrary) {
  ParseOptions options;
  options.firmware_dir = "/opt/fw";
  const RoverConfig config = parse_config(
      R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"virtual": {"firmware": "romi-rover"}}}]})",
      options);
  expect_simulator_missing(config, 0, "transport.virtual");
}

// The default virtual rover, parsed against the build's images (its rpc device reads the schema beside its
// image at parse time).
TEST(DevicesWithoutSimulator, VirtualRingNamesTheLibrary) {
  ParseOptions options;
  options.firmware_dir = TETHER_FIRMWARE_DIR;
  const RoverConfig config = parse_config(default_virtual_rover_config(), options);
  std::size_t ring = config.devices.size();
  for (std::size_t i = 0; i < config.devices.size(); ++i) {
    if (std::holds_alternative<VirtualRingTransport>(config.devices[i].transport)) ring = i;
  }
  ASSERT_LT(ring, config.devices.size());
  expect_simulator_missing(config, ring, "transport.virtual_ring");
}

TEST(DevicesWithoutSimulator, OpenRoverNamesTheDevice) {
  ParseOptions options;
  options.firmware_dir = TETHER_FIRMWARE_DIR;
  const RoverConfig config = parse_config(default_virtual_rover_config(), options);
  boost::asio::io_context io;
  error_code error;
  std::string message;
  const Rover rover = open_rover(config, io.get_executor(), error, &message);
  EXPECT_FALSE(rover.is_open());
  EXPECT_EQ(error, make_error_code(DevicesError::not_supported));
  EXPECT_EQ(message.rfind("devices[0].transport.virtual", 0), 0u) << message;
}

}  // namespace
}  // namespace tether::devices
