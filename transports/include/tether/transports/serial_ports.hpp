/// @file serial_ports.hpp
/// Finding serial ports by what the board is, not where the kernel put it: a USB identity (vendor id,
/// product id, serial number: any subset) or a `/dev/serial/by-id` name, matched against what the kernel
/// and udev publish (`/sys/class/tty/<tty>/device/..` attributes, `/dev/serial/by-id` symlinks). No
/// daemon, no root, nothing opened: only file names and attributes are read.
///
/// @code
///   transports::PortSpec spec;
///   spec.usb.vid = "2341"; spec.usb.pid = "0043";                 // an Arduino Uno R3, wherever it is
///   std::string message;
///   const std::string path = transports::resolve_port(spec, error, &message);  // "/dev/ttyACM1"
///   // no match: TransportError::no_matching_port, message lists the ports seen
/// @endcode
///
/// Roots: the sysfs and dev trees are read under `PortRoots`, by default `/sys` and `/dev`, or the
/// folders named by the environment variables `TETHER_SYSFS_ROOT` and `TETHER_DEV_ROOT` (tests build a
/// fake tree there: `<sysfs>/class/tty/ttyACM0/device -> <sysfs>/devices/.../1-1:1.0`, `idVendor` & co in
/// `<sysfs>/devices/.../1-1`, and `<dev>/serial/by-id/<name> -> ../../ttyACM0`).
///
/// Listed ports: every tty with a `device` in sysfs except the legacy 8250 UARTs the kernel registers
/// whether or not they exist (`ttyS0..31`; a `/dev/serial/by-id` name brings one back), plus every
/// `/dev/serial/by-id` name whose target is not such a tty (a pty behind a stable name, as in tests).
#pragma once

#include <boost/system/error_code.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tether::transports {

/// A USB device's identity; an empty member matches anything.
struct UsbIdentity {
  std::string vid = {};     ///< Vendor id: 4 hex digits (`2341`), compared case-insensitively.
  std::string pid = {};     ///< Product id: 4 hex digits (`0043`), compared case-insensitively.
  std::string serial = {};  ///< iSerial string (`75833353035351E0E1A1`), compared exactly.
  /// True when no member is set.
  bool empty() const { return vid.empty() && pid.empty() && serial.empty(); }
};

/// Which serial port: a path, an identity, or both. With an identity the port is looked up when it is
/// opened (and again after it vanished); a path given as well must be one of the matches.
struct PortSpec {
  std::string path = {};   ///< `/dev/ttyACM0`; empty: found by identity.
  UsbIdentity usb = {};    ///< USB identity (any subset).
  std::string by_id = {};  ///< A `/dev/serial/by-id/` name (`usb-Arduino..._0043_7583...-if00`) or its full path.
  /// True when the port is named by identity (`usb` or `by_id`), not only by path.
  bool has_identity() const { return !usb.empty() || !by_id.empty(); }
  /// `usb 2341:0043 serial 7583...`, `by-id usb-Arduino...`, or the path: for messages.
  std::string describe() const;
};

/// Where the sysfs and dev trees are read.
struct PortRoots {
  std::filesystem::path sysfs = "/sys";  ///< Root of sysfs.
  std::filesystem::path dev = "/dev";    ///< Root of the device files (`<dev>/serial/by-id`).
  /// `/sys` and `/dev`, or `$TETHER_SYSFS_ROOT` and `$TETHER_DEV_ROOT` when set and not empty.
  static PortRoots from_environment();
};

/// One serial port as the system describes it.
struct SerialPortInfo {
  std::string path;          ///< What to open: `<dev>/ttyACM0`, or a by-id name's target.
  std::string by_id;         ///< Its `/dev/serial/by-id` name (file name only), or empty.
  std::string vid;           ///< USB vendor id, lower-case hex (empty when not USB).
  std::string pid;           ///< USB product id, lower-case hex.
  std::string serial;        ///< USB serial number, or empty.
  std::string manufacturer;  ///< USB manufacturer string, or empty.
  std::string product;       ///< USB product string, or empty.
  /// `/dev/ttyACM0 (2341:0043 serial X, by-id Y)`: for candidate lists.
  std::string describe() const;
};

/// Every serial port under `roots`, sorted by path. Unreadable entries are skipped, never an error.
std::vector<SerialPortInfo> list_serial_ports(const PortRoots& roots = PortRoots::from_environment());

/// True when `port` has every identity member `spec` sets (its path is not compared).
bool matches(const SerialPortInfo& port, const PortSpec& spec);

/// What is wrong with a USB id (`vid`, `pid`) as text, or nothing: it must be exactly 4 hex digits.
std::optional<std::string> usb_id_problem(std::string_view id);
/// What is wrong with a by-id name, or nothing: non-empty, a file name or `/dev/serial/by-id/<name>`.
std::optional<std::string> by_id_problem(std::string_view name);

/// The path to open for `spec`: its path when it has no identity (nothing is read), else the one port of
/// `list_serial_ports(roots)` that matches (and, with a path too, is that path). Errors (null result):
/// `TransportError::no_matching_port`, `TransportError::several_matching_ports`; `*message` (when given)
/// then says what was sought and lists the candidates (at most 10, then how many more).
std::string resolve_port(const PortSpec& spec, boost::system::error_code& error, std::string* message = nullptr,
                         const PortRoots& roots = PortRoots::from_environment());

}  // namespace tether::transports
