/// @file fake_port_tree.hpp
/// A fake sysfs + dev tree in a fresh temporary folder, laid out as the kernel and udev lay out theirs, for
/// tests of port lookup by identity (serial_ports.hpp): point `TETHER_SYSFS_ROOT` / `TETHER_DEV_ROOT` (or a
/// `PortRoots`) at `sysfs()` / `dev()`. Removed with everything in it on destruction.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace tether::transports::testing {

/// The fake tree; see the file overview.
class FakePortTree {
 public:
  FakePortTree() {
    std::string pattern = (std::filesystem::temp_directory_path() / "tether-ports-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) std::abort();
    root_ = pattern;
    std::filesystem::create_directories(sysfs() / "class" / "tty");
    std::filesystem::create_directories(dev() / "serial" / "by-id");
  }
  ~FakePortTree() {
    std::error_code ignored;
    std::filesystem::remove_all(root_, ignored);
  }
  FakePortTree(const FakePortTree&) = delete;
  FakePortTree& operator=(const FakePortTree&) = delete;

  /// The sysfs root.
  std::filesystem::path sysfs() const { return root_ / "sys"; }
  /// The dev root.
  std::filesystem::path dev() const { return root_ / "dev"; }

  /// A USB serial tty `name` (ttyACM0) on USB device `bus_port` (1-1) with these attributes (an empty one
  /// is left out, as the kernel does for a device without that string); `interface_level` 0 puts the tty
  /// right under the interface (cdc_acm), 1 one folder deeper (usb-serial drivers: ftdi_sio, ch341).
  /// Also creates `<dev>/<name>` as a regular file (nothing opens it).
  void add_usb_tty(const std::string& name, const std::string& bus_port, const std::string& vid,
                   const std::string& pid, const std::string& serial = "", const std::string& manufacturer = "",
                   const std::string& product = "", int interface_level = 0) {
    const std::filesystem::path usb = sysfs() / "devices" / "pci0000:00" / "usb1" / bus_port;
    std::filesystem::path device = usb / (bus_port + ":1.0");
    if (interface_level > 0) device /= name;
    std::filesystem::create_directories(device);
    write(usb / "idVendor", vid);
    write(usb / "idProduct", pid);
    if (!serial.empty()) write(usb / "serial", serial);
    if (!manufacturer.empty()) write(usb / "manufacturer", manufacturer);
    if (!product.empty()) write(usb / "product", product);
    add_tty(name, device);
  }
  /// A tty with a non-USB device (`driver`: serial8250 for the legacy UARTs, which are not listed).
  void add_platform_tty(const std::string& name, const std::string& driver) {
    const std::filesystem::path device = sysfs() / "devices" / "platform" / (driver + "." + name);
    std::filesystem::create_directories(device);
    const std::filesystem::path drivers = sysfs() / "bus" / "platform" / "drivers" / driver;
    std::filesystem::create_directories(drivers);
    std::filesystem::create_symlink(drivers, device / "driver");
    add_tty(name, device);
  }
  /// A tty without a device (a virtual console): never listed.
  void add_virtual_tty(const std::string& name) {
    std::filesystem::create_directories(sysfs() / "devices" / "virtual" / "tty" / name);
    std::filesystem::create_directory_symlink(sysfs() / "devices" / "virtual" / "tty" / name,
                                              sysfs() / "class" / "tty" / name);
  }
  /// `<dev>/serial/by-id/<name>` -> `target` (relative `../../ttyACM0` as udev makes it, or absolute);
  /// replaces an existing one (udev's rename is atomic; this is close enough for a test).
  void add_by_id(const std::string& name, const std::string& target) {
    const std::filesystem::path link = dev() / "serial" / "by-id" / name;
    std::error_code ignored;
    std::filesystem::remove(link, ignored);
    std::filesystem::create_symlink(target, link);
  }
  /// Removes a by-id name (the board was unplugged).
  void remove_by_id(const std::string& name) {
    std::error_code ignored;
    std::filesystem::remove(dev() / "serial" / "by-id" / name, ignored);
  }

 private:
  void add_tty(const std::string& name, const std::filesystem::path& device) {
    const std::filesystem::path tty = device / "tty" / name;
    std::filesystem::create_directories(tty);
    std::filesystem::create_directory_symlink(device, tty / "device");
    std::filesystem::create_directory_symlink(tty, sysfs() / "class" / "tty" / name);
    write(dev() / name, "");
  }
  static void write(const std::filesystem::path& file, const std::string& text) {
    std::ofstream(file) << text << "\n";
  }

  std::filesystem::path root_;
};

/// Points the port lookup at a FakePortTree (TETHER_SYSFS_ROOT, TETHER_DEV_ROOT) while it lives; the
/// variables are unset again however the test ends.
class UsingFakePortTree {
 public:
  /// Sets both variables to `tree`'s roots.
  explicit UsingFakePortTree(const FakePortTree& tree) {
    ::setenv("TETHER_SYSFS_ROOT", tree.sysfs().c_str(), 1);
    ::setenv("TETHER_DEV_ROOT", tree.dev().c_str(), 1);
  }
  ~UsingFakePortTree() {
    ::unsetenv("TETHER_SYSFS_ROOT");
    ::unsetenv("TETHER_DEV_ROOT");
  }
  UsingFakePortTree(const UsingFakePortTree&) = delete;
  UsingFakePortTree& operator=(const UsingFakePortTree&) = delete;
};

}  // namespace tether::transports::testing
