// A serial device named by identity opens the port that has it (a pty behind a by-id name in a fake tree),
// and a missing or ambiguous board is a ConfigError naming `...serial.port` and listing the candidates.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/testing/fake_port_tree.hpp"

namespace tether::devices {
namespace {

DeviceConfig romi_on(const std::string& serial) {
  return parse_config(R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"serial": )" + serial + "}}]}")
      .devices.at(0);
}

TEST(DevicesSerialIdentity, OpensThePortBehindTheByIdName) {
  transports::IoThread io;
  auto pty = transports::PtyStream::open(io.executor());
  transports::testing::FakePortTree tree;
  tree.add_by_id("usb-Virtual_Uno_1-if00", pty->slave_path());
  const transports::testing::UsingFakePortTree use(tree);
  const OpenedTransport opened =
      open_transport(romi_on(R"({"port": {"by_id": "usb-Virtual_Uno_1-if00"}, "boot_wait_ms": 0})"), io.executor());
  ASSERT_TRUE(opened.stream);
  EXPECT_EQ(opened.stream->description(), "serial " + pty->slave_path() + " 115200 8N1");
  opened.stream->close();
  pty->close();
}

TEST(DevicesSerialIdentity, NoMatchingBoardNamesThePortAndTheCandidates) {
  transports::IoThread io;
  transports::testing::FakePortTree tree;
  tree.add_usb_tty("ttyACM0", "1-1", "2341", "0043", "A1");
  tree.add_usb_tty("ttyACM1", "1-2", "2341", "0043", "B2");
  const transports::testing::UsingFakePortTree use(tree);
  try {
    (void)open_transport(romi_on(R"({"port": {"usb": {"serial": "C3"}}, "boot_wait_ms": 0})"), io.executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.code(), make_error_code(transports::TransportError::no_matching_port));
    EXPECT_EQ(error.path(), "transport.serial.port");
    EXPECT_EQ(error.detail(), "no serial port matches usb *:* serial C3 (ports: " + (tree.dev() / "ttyACM0").string() +
                                  " (2341:0043 serial A1); " + (tree.dev() / "ttyACM1").string() +
                                  " (2341:0043 serial B2))");
  }
  try {
    (void)open_transport(romi_on(R"({"port": {"usb": {"vid": "2341"}}, "boot_wait_ms": 0})"), io.executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.code(), make_error_code(transports::TransportError::several_matching_ports));
    EXPECT_EQ(error.path(), "transport.serial.port");
  }
}

TEST(DevicesSerialIdentity, AMatchThatIsNotATtyIsAClearError) {
  transports::IoThread io;
  transports::testing::FakePortTree tree;
  tree.add_usb_tty("ttyACM0", "1-1", "2341", "0043", "A1");  // <dev>/ttyACM0 is a regular file
  const transports::testing::UsingFakePortTree use(tree);
  try {
    (void)open_transport(romi_on(R"({"port": {"usb": {"serial": "A1"}}, "boot_wait_ms": 0})"), io.executor());
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.path(), "transport.serial.port");
    EXPECT_EQ(error.detail(), (tree.dev() / "ttyACM0").string() + ": not a serial port (Inappropriate ioctl for device)");
  }
}

}  // namespace
}  // namespace tether::devices
