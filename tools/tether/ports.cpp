// `tether ports [--config FILE] [--json]`: the serial ports of this machine as the kernel and udev describe
// them (path, /dev/serial/by-id name, USB VID:PID, serial number, manufacturer, product), and with --config
// which device of a rover configuration each one is (its `"port"` identity or its path).
//
// Output contract: a table on stdout (a header line, one line per port; `no serial ports found` when there are
// none), or with --json one object `{"ports": [...], "unmatched": [...]}`; with --config the devices whose
// serial port is not there are listed after the table (`not found: arm (usb 2341:0043)`) and in "unmatched".
// Exit status 0 (also when nothing is found); 2 usage errors and a configuration that does not load.
// TETHER_SYSFS_ROOT / TETHER_DEV_ROOT move the trees read (tests).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "tether/devices/config.hpp"
#include "tether/transports/serial_ports.hpp"

namespace tether::cli {

namespace {

const CommandText& ports_command() {
  static const CommandText text(
      "ports",
      "usage: tether ports [--config FILE] [--json]\n"
      "\n"
      "Lists the serial ports (USB CDC and USB-serial adapters, on-board UARTs, /dev/serial/by-id names): path,\n"
      "by-id name, USB VID:PID, serial number, manufacturer and product. A configuration can name a board by\n"
      "these instead of its path, which changes when it is plugged elsewhere:\n"
      "  \"transport\": {\"serial\": {\"port\": {\"usb\": {\"vid\": \"2341\", \"pid\": \"0043\", \"serial\": \"7583...\"}}}}\n"
      "\n"
      "  --config FILE  also show which device of the rover configuration FILE each port is, and list its\n"
      "                 serial devices that no port matches\n"
      "  --json         one JSON object: {\"ports\": [{\"path\", \"by_id\", \"vid\", \"pid\", \"serial\",\n"
      "                 \"manufacturer\", \"product\", \"devices\"}], \"unmatched\": [{\"device\", \"port\"}]}\n"
      "\n"
      "Reads /sys/class/tty and /dev/serial/by-id (TETHER_SYSFS_ROOT and TETHER_DEV_ROOT name other roots);\n"
      "opens no port.\n"
      "\n"
      "Exit status: 0 (also when no port is found); 2 usage errors and a configuration that does not load.\n");
  return text;
}

std::string same_file(const std::string& path) {
  std::error_code error;
  const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, error);
  return error ? std::filesystem::path(path).lexically_normal().string() : canonical.string();
}

// True when the serial device `serial` names `port`: by identity (and path, when it gives both), or by its
// path (the port's own, or its by-id name's).
bool names_port(const devices::SerialTransport& serial, const transports::SerialPortInfo& port,
                const transports::PortRoots& roots) {
  const transports::PortSpec spec = serial.port();
  const auto path_matches = [&] {
    if (same_file(spec.path) == same_file(port.path)) return true;
    return !port.by_id.empty() && same_file(spec.path) == same_file((roots.dev / "serial" / "by-id" / port.by_id).string());
  };
  if (spec.has_identity()) return transports::matches(port, spec) && (spec.path.empty() || path_matches());
  return path_matches();
}

std::string or_dash(const std::string& text) { return text.empty() ? "-" : text; }

}  // namespace

int run_ports(int argc, char** argv) {
  std::string config_file;
  bool json = false;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--json") {
      json = true;
    } else if (argument == "--config") {
      if (i + 1 >= argc || std::string_view(argv[i + 1]).empty()) return ports_command().usage_error("--config needs a file");
      config_file = argv[++i];
    } else {
      return ports_command().usage_error("unknown argument " + std::string(argument));
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, ports_command(), own)) return *status;

  std::vector<const devices::DeviceConfig*> serial_devices;
  devices::RoverConfig config;
  if (!config_file.empty()) {
    try {
      devices::ParseOptions where;
      where.firmware_dir = firmware_dir();
      config = devices::load_config(config_file, where);
    } catch (const devices::ConfigError& error) {
      return ports_command().fail(error.what());
    }
    for (const devices::DeviceConfig& device : config.devices) {
      if (std::holds_alternative<devices::SerialTransport>(device.transport)) serial_devices.push_back(&device);
    }
  }

  const transports::PortRoots roots = transports::PortRoots::from_environment();
  const std::vector<transports::SerialPortInfo> ports = transports::list_serial_ports(roots);
  std::vector<std::vector<std::string>> matched(ports.size());
  std::vector<const devices::DeviceConfig*> unmatched;
  for (const devices::DeviceConfig* device : serial_devices) {
    const auto& serial = std::get<devices::SerialTransport>(device->transport);
    bool found = false;
    for (std::size_t i = 0; i < ports.size(); ++i) {
      if (!names_port(serial, ports[i], roots)) continue;
      matched[i].push_back(device->name);
      found = true;
    }
    if (!found) unmatched.push_back(device);
  }

  if (json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < ports.size(); ++i) {
      const transports::SerialPortInfo& port = ports[i];
      nlohmann::ordered_json entry = {{"path", port.path},         {"by_id", port.by_id},
                                      {"vid", port.vid},           {"pid", port.pid},
                                      {"serial", port.serial},     {"manufacturer", port.manufacturer},
                                      {"product", port.product}};
      if (!config_file.empty()) entry["devices"] = matched[i];
      list.push_back(std::move(entry));
    }
    nlohmann::ordered_json report = {{"ports", list}};
    if (!config_file.empty()) {
      nlohmann::ordered_json missing = nlohmann::ordered_json::array();
      for (const devices::DeviceConfig* device : unmatched) {
        missing.push_back({{"device", device->name},
                           {"port", std::get<devices::SerialTransport>(device->transport).port().describe()}});
      }
      report["unmatched"] = missing;
    }
    out().line(dump(report));
    return 0;
  }

  if (ports.empty()) {
    out().line("no serial ports found");
  } else {
    std::vector<std::vector<std::string>> rows;
    rows.push_back({"PORT", "VID:PID", "SERIAL", "MANUFACTURER", "PRODUCT", "BY-ID"});
    if (!config_file.empty()) rows.front().push_back("DEVICE");
    for (std::size_t i = 0; i < ports.size(); ++i) {
      const transports::SerialPortInfo& port = ports[i];
      std::vector<std::string> row = {port.path, port.vid.empty() ? "-" : port.vid + ":" + port.pid, or_dash(port.serial),
                                      or_dash(port.manufacturer), or_dash(port.product), or_dash(port.by_id)};
      if (!config_file.empty()) {
        std::string names;
        for (const std::string& name : matched[i]) names += (names.empty() ? "" : ",") + name;
        row.push_back(or_dash(names));
      }
      rows.push_back(std::move(row));
    }
    std::vector<std::size_t> widths(rows.front().size(), 0);
    for (const auto& row : rows) {
      for (std::size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], row[c].size());
    }
    for (const auto& row : rows) {
      std::string line;
      for (std::size_t c = 0; c < row.size(); ++c) {
        line += row[c];
        if (c + 1 < row.size()) line.append(widths[c] + 2 - row[c].size(), ' ');
      }
      out().line(line);
    }
  }
  for (const devices::DeviceConfig* device : unmatched) {
    out().line("not found: " + device->name + " (" +
               std::get<devices::SerialTransport>(device->transport).port().describe() + ")");
  }
  return 0;
}

}  // namespace tether::cli
