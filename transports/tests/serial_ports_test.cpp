// Serial ports by identity: listing and matching against a fake sysfs/by-id tree laid out as the kernel's.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "tether/transports/serial_ports.hpp"
#include "tether/transports/testing/fake_port_tree.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::transports {
namespace {

using testing::FakePortTree;

constexpr const char* kUnoById = "usb-Arduino__www.arduino.cc__0043_75833353035351E0E1A1-if00";

// Two Unos (same VID:PID, different serials), an FTDI adapter, a legacy UART, a Pi's UART, a console.
struct Bench {
  FakePortTree tree;
  PortRoots roots{tree.sysfs(), tree.dev()};
  Bench() {
    tree.add_usb_tty("ttyACM0", "1-1", "2341", "0043", "75833353035351E0E1A1", "Arduino (www.arduino.cc)",
                     "Arduino Uno");
    tree.add_usb_tty("ttyACM1", "1-2", "2341", "0043", "95530343834351A0B1C2", "Arduino (www.arduino.cc)",
                     "Arduino Uno");
    tree.add_usb_tty("ttyUSB0", "1-3", "0403", "6001", "A50285BI", "FTDI", "FT232R USB UART", 1);
    tree.add_platform_tty("ttyS0", "serial8250");
    tree.add_platform_tty("ttyAMA0", "uart-pl011");
    tree.add_virtual_tty("tty1");
    tree.add_by_id(kUnoById, "../../ttyACM0");
    tree.add_by_id("usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0", "../../ttyUSB0");
  }
  std::string path(const std::string& name) const { return (tree.dev() / name).string(); }
};

TEST(SerialPorts, ListsUsbAndPlatformTtysWithTheirAttributesAndByIdNames) {
  Bench bench;
  const auto ports = list_serial_ports(bench.roots);
  ASSERT_EQ(ports.size(), 4u);  // not ttyS0 (legacy 8250), not tty1 (no device)
  EXPECT_EQ(ports[0].path, bench.path("ttyACM0"));
  EXPECT_EQ(ports[0].by_id, kUnoById);
  EXPECT_EQ(ports[0].vid, "2341");
  EXPECT_EQ(ports[0].pid, "0043");
  EXPECT_EQ(ports[0].serial, "75833353035351E0E1A1");
  EXPECT_EQ(ports[0].manufacturer, "Arduino (www.arduino.cc)");
  EXPECT_EQ(ports[0].product, "Arduino Uno");
  EXPECT_EQ(ports[1].path, bench.path("ttyACM1"));
  EXPECT_EQ(ports[1].by_id, "");
  EXPECT_EQ(ports[2].path, bench.path("ttyAMA0"));
  EXPECT_EQ(ports[2].vid, "");
  EXPECT_EQ(ports[3].path, bench.path("ttyUSB0"));  // usb-serial: the USB device is one folder further up
  EXPECT_EQ(ports[3].vid, "0403");
  EXPECT_EQ(ports[3].serial, "A50285BI");
  EXPECT_EQ(ports[3].by_id, "usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0");
}

TEST(SerialPorts, ALegacyUartNamedByIdIsListed) {
  Bench bench;
  bench.tree.add_by_id("pci-legacy", "../../ttyS0");
  const auto ports = list_serial_ports(bench.roots);
  ASSERT_EQ(ports.size(), 5u);
  EXPECT_EQ(ports[3].path, bench.path("ttyS0"));
  EXPECT_EQ(ports[3].by_id, "pci-legacy");
}

TEST(SerialPorts, AByIdNameOfAPtyIsAPortAtItsTarget) {
  Bench bench;
  const std::string pty = (bench.tree.dev() / "pts-7").string();
  { std::ofstream(pty) << ""; }
  bench.tree.add_by_id("usb-Virtual_Uno_1-if00", pty);
  bench.tree.add_by_id("usb-stale-if00", (bench.tree.dev() / "pts-99").string());  // target gone: not listed
  const auto ports = list_serial_ports(bench.roots);
  ASSERT_EQ(ports.size(), 5u);
  EXPECT_EQ(ports[0].path, pty);  // sorted by path: <dev>/pts-7 first
  EXPECT_EQ(ports[0].by_id, "usb-Virtual_Uno_1-if00");
}

TEST(SerialPorts, ResolvesAnyIdentitySubset) {
  Bench bench;
  error_code error;
  PortSpec spec;
  spec.usb.serial = "95530343834351A0B1C2";
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyACM1"));
  EXPECT_FALSE(error);
  spec = PortSpec();
  spec.usb.vid = "0403";  // case and subset: VID only
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyUSB0"));
  spec = PortSpec();
  spec.usb = {"2341", "0043", "75833353035351E0E1A1"};
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyACM0"));
  spec = PortSpec();
  spec.by_id = kUnoById;
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyACM0"));
  spec.by_id = std::string("/dev/serial/by-id/") + kUnoById;  // the full name works too
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyACM0"));
  spec = PortSpec();
  spec.usb.pid = "0043";
  spec.path = bench.path("ttyACM1");  // a path narrows several matches to one
  EXPECT_EQ(resolve_port(spec, error, nullptr, bench.roots), bench.path("ttyACM1"));
  EXPECT_FALSE(error);
}

TEST(SerialPorts, HexIdsCompareCaseInsensitively) {
  FakePortTree tree;
  tree.add_usb_tty("ttyACM0", "1-1", "1a86", "7523");
  PortSpec spec;
  spec.usb.vid = "1A86";  // as printed on a label
  spec.usb.pid = "7523";
  error_code error;
  EXPECT_EQ(resolve_port(spec, error, nullptr, PortRoots{tree.sysfs(), tree.dev()}), (tree.dev() / "ttyACM0").string());
}

TEST(SerialPorts, APathAloneIsNotLookedUp) {
  PortSpec spec;
  spec.path = "/dev/does-not-exist";
  error_code error;
  EXPECT_EQ(resolve_port(spec, error, nullptr, PortRoots{"/nonexistent", "/nonexistent"}), "/dev/does-not-exist");
  EXPECT_FALSE(error);
}

TEST(SerialPorts, NoMatchListsEveryPort) {
  Bench bench;
  PortSpec spec;
  spec.usb.vid = "2341";
  spec.usb.pid = "0042";
  error_code error;
  std::string message;
  EXPECT_EQ(resolve_port(spec, error, &message, bench.roots), "");
  EXPECT_EQ(error, make_error_code(TransportError::no_matching_port));
  EXPECT_EQ(message, "no serial port matches usb 2341:0042 (ports: " + bench.path("ttyACM0") +
                         " (2341:0043 serial 75833353035351E0E1A1, by-id " + kUnoById + "); " + bench.path("ttyACM1") +
                         " (2341:0043 serial 95530343834351A0B1C2); " + bench.path("ttyAMA0") + "; " +
                         bench.path("ttyUSB0") +
                         " (0403:6001 serial A50285BI, by-id usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0))");
}

TEST(SerialPorts, NoPortsAtAll) {
  FakePortTree tree;
  PortSpec spec;
  spec.by_id = "usb-x";
  error_code error;
  std::string message;
  resolve_port(spec, error, &message, PortRoots{tree.sysfs(), tree.dev()});
  EXPECT_EQ(error, make_error_code(TransportError::no_matching_port));
  EXPECT_EQ(message, "no serial port matches by-id usb-x (no serial ports found)");
}

TEST(SerialPorts, SeveralMatchesListTheMatches) {
  Bench bench;
  PortSpec spec;
  spec.usb.vid = "2341";
  error_code error;
  std::string message;
  EXPECT_EQ(resolve_port(spec, error, &message, bench.roots), "");
  EXPECT_EQ(error, make_error_code(TransportError::several_matching_ports));
  EXPECT_EQ(message, "several serial ports match usb 2341:* (" + bench.path("ttyACM0") +
                         " (2341:0043 serial 75833353035351E0E1A1, by-id " + kUnoById + "); " + bench.path("ttyACM1") +
                         " (2341:0043 serial 95530343834351A0B1C2))");
}

TEST(SerialPorts, APathThatIsNotAMatch) {
  Bench bench;
  PortSpec spec;
  spec.usb.vid = "0403";
  spec.path = bench.path("ttyACM0");
  error_code error;
  std::string message;
  resolve_port(spec, error, &message, bench.roots);
  EXPECT_EQ(error, make_error_code(TransportError::no_matching_port));
  EXPECT_EQ(message.rfind("no serial port matches usb 0403:* at " + bench.path("ttyACM0") + " (ports: ", 0), 0u)
      << message;
}

TEST(SerialPorts, CandidateListsAreBounded) {
  FakePortTree tree;
  for (int i = 0; i < 14; ++i) {
    tree.add_usb_tty("ttyACM" + std::to_string(i), "1-" + std::to_string(i + 1), "2341", "0043");
  }
  PortSpec spec;
  spec.usb.pid = "0043";
  error_code error;
  std::string message;
  resolve_port(spec, error, &message, PortRoots{tree.sysfs(), tree.dev()});
  EXPECT_EQ(error, make_error_code(TransportError::several_matching_ports));
  EXPECT_NE(message.find(" and 4 more)"), std::string::npos) << message;
}

TEST(SerialPorts, TheEnvironmentNamesTheRoots) {
  ::setenv("TETHER_SYSFS_ROOT", "/tmp/fake-sys", 1);
  ::setenv("TETHER_DEV_ROOT", "/tmp/fake-dev", 1);
  const PortRoots roots = PortRoots::from_environment();
  EXPECT_EQ(roots.sysfs, "/tmp/fake-sys");
  EXPECT_EQ(roots.dev, "/tmp/fake-dev");
  ::unsetenv("TETHER_SYSFS_ROOT");
  ::setenv("TETHER_DEV_ROOT", "", 1);
  const PortRoots defaults = PortRoots::from_environment();
  EXPECT_EQ(defaults.sysfs, "/sys");
  EXPECT_EQ(defaults.dev, "/dev");
  ::unsetenv("TETHER_DEV_ROOT");
}

TEST(SerialPorts, MalformedIdentities) {
  EXPECT_FALSE(usb_id_problem("2341"));
  EXPECT_FALSE(usb_id_problem("abCD"));
  EXPECT_TRUE(usb_id_problem("234"));
  EXPECT_TRUE(usb_id_problem("23410"));
  EXPECT_TRUE(usb_id_problem("0x41"));
  EXPECT_TRUE(usb_id_problem("23G1"));
  EXPECT_TRUE(usb_id_problem(""));
  EXPECT_FALSE(by_id_problem("usb-Arduino-if00"));
  EXPECT_FALSE(by_id_problem("/dev/serial/by-id/usb-Arduino-if00"));
  EXPECT_TRUE(by_id_problem(""));
  EXPECT_TRUE(by_id_problem("/dev/serial/by-id/"));
  EXPECT_TRUE(by_id_problem("../ttyACM0"));
  EXPECT_TRUE(by_id_problem("/dev/ttyACM0"));
}

}  // namespace
}  // namespace tether::transports
