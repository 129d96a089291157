// Serial ports by identity: sysfs attributes and /dev/serial/by-id names.
#include "tether/transports/serial_ports.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <map>
#include <system_error>

#include "tether/transports/transport_error.hpp"

namespace tether::transports {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kByIdFolder = "/dev/serial/by-id/";
// Candidates a message lists at most: enough to spot the board, short on a machine full of adapters.
constexpr std::size_t kListedCandidates = 10;

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
  return text;
}

// First line of a sysfs attribute, or empty.
std::string read_attribute(const fs::path& file) {
  std::ifstream stream(file);
  std::string line;
  if (!stream || !std::getline(stream, line)) return {};
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

// The USB device folder above a tty's `device` (the interface for CDC ACM, one level deeper for
// usb-serial drivers): the first ancestor with an idVendor.
std::optional<fs::path> usb_device_folder(const fs::path& device, const fs::path& sysfs_root) {
  std::error_code error;
  fs::path folder = fs::canonical(device, error);
  if (error) return std::nullopt;
  const fs::path root = fs::weakly_canonical(sysfs_root, error);
  for (int level = 0; level < 5 && !folder.empty() && folder != root && folder != folder.root_path(); ++level) {
    if (fs::exists(folder / "idVendor", error)) return folder;
    folder = folder.parent_path();
  }
  return std::nullopt;
}

std::string driver_name(const fs::path& device) {
  std::error_code error;
  const fs::path driver = fs::read_symlink(device / "driver", error);
  return error ? std::string() : driver.filename().string();
}

// Lexically normal absolute form of a symlink's target (relative targets are relative to its folder).
fs::path link_target(const fs::path& link, std::error_code& error) {
  fs::path target = fs::read_symlink(link, error);
  if (error) return {};
  if (target.is_relative()) target = link.parent_path() / target;
  return target.lexically_normal();
}

std::string same_file_key(const std::string& path) {
  std::error_code error;
  const fs::path canonical = fs::weakly_canonical(path, error);
  return error ? fs::path(path).lexically_normal().string() : canonical.string();
}

}  // namespace

std::string PortSpec::describe() const {
  std::string text;
  const auto add = [&text](const std::string& part) { text += (text.empty() ? "" : " ") + part; };
  if (!usb.empty()) {
    std::string ids = (usb.vid.empty() ? "*" : usb.vid) + ":" + (usb.pid.empty() ? "*" : usb.pid);
    add("usb " + ids + (usb.serial.empty() ? "" : " serial " + usb.serial));
  }
  if (!by_id.empty()) add("by-id " + by_id);
  if (!path.empty()) add(text.empty() ? path : "at " + path);
  return text;
}

PortRoots PortRoots::from_environment() {
  PortRoots roots;
  if (const char* sysfs = std::getenv("TETHER_SYSFS_ROOT"); sysfs != nullptr && *sysfs != '\0') roots.sysfs = sysfs;
  if (const char* dev = std::getenv("TETHER_DEV_ROOT"); dev != nullptr && *dev != '\0') roots.dev = dev;
  return roots;
}

std::string SerialPortInfo::describe() const {
  std::string details;
  const auto add = [&details](const std::string& part) { details += (details.empty() ? "" : ", ") + part; };
  if (!vid.empty() || !pid.empty()) add(vid + ":" + pid + (serial.empty() ? "" : " serial " + serial));
  if (!by_id.empty()) add("by-id " + by_id);
  return details.empty() ? path : path + " (" + details + ")";
}

std::vector<SerialPortInfo> list_serial_ports(const PortRoots& roots) {
  std::error_code error;
  // by-id names first: name -> target.
  std::map<std::string, fs::path> by_id;
  const fs::path by_id_folder = roots.dev / "serial" / "by-id";
  for (fs::directory_iterator it(by_id_folder, error), end; !error && it != end; it.increment(error)) {
    std::error_code link_error;
    const fs::path target = link_target(it->path(), link_error);
    if (link_error || !fs::exists(target, link_error)) continue;  // stale name: the board is gone
    by_id.emplace(it->path().filename().string(), target);
  }

  std::map<std::string, SerialPortInfo> ports;  // by tty name or target path
  error.clear();
  for (fs::directory_iterator it(roots.sysfs / "class" / "tty", error), end; !error && it != end; it.increment(error)) {
    const std::string name = it->path().filename().string();
    std::error_code entry_error;
    const fs::path device = it->path() / "device";
    if (!fs::exists(device, entry_error)) continue;  // virtual terminals, ptys
    SerialPortInfo port;
    port.path = (roots.dev / name).string();
    if (const auto usb = usb_device_folder(device, roots.sysfs)) {
      port.vid = lower(read_attribute(*usb / "idVendor"));
      port.pid = lower(read_attribute(*usb / "idProduct"));
      port.serial = read_attribute(*usb / "serial");
      port.manufacturer = read_attribute(*usb / "manufacturer");
      port.product = read_attribute(*usb / "product");
    } else if (driver_name(device) == "serial8250") {
      port.path.clear();  // kept only if a by-id name points at it
    }
    ports.emplace(name, std::move(port));
  }

  std::vector<SerialPortInfo> result;
  for (const auto& [name, target] : by_id) {
    const auto tty = ports.find(target.filename().string());
    if (tty != ports.end() && target.parent_path() == (roots.dev / "tty").lexically_normal().parent_path()) {
      if (tty->second.path.empty()) tty->second.path = (roots.dev / tty->first).string();
      if (tty->second.by_id.empty()) tty->second.by_id = name;
      continue;
    }
    SerialPortInfo port;
    port.path = target.string();
    port.by_id = name;
    result.push_back(std::move(port));
  }
  for (auto& [name, port] : ports) {
    if (!port.path.empty()) result.push_back(std::move(port));
  }
  std::sort(result.begin(), result.end(),
            [](const SerialPortInfo& a, const SerialPortInfo& b) { return a.path < b.path; });
  return result;
}

bool matches(const SerialPortInfo& port, const PortSpec& spec) {
  if (!spec.usb.vid.empty() && lower(spec.usb.vid) != port.vid) return false;
  if (!spec.usb.pid.empty() && lower(spec.usb.pid) != port.pid) return false;
  if (!spec.usb.serial.empty() && spec.usb.serial != port.serial) return false;
  if (!spec.by_id.empty()) {
    std::string_view name = spec.by_id;
    if (name.substr(0, kByIdFolder.size()) == kByIdFolder) name.remove_prefix(kByIdFolder.size());
    if (port.by_id != name) return false;
  }
  return true;
}

std::optional<std::string> usb_id_problem(std::string_view id) {
  const bool hex = std::all_of(id.begin(), id.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; });
  if (id.size() != 4 || !hex) return "expected 4 hex digits (\"2341\")";
  return std::nullopt;
}

std::optional<std::string> by_id_problem(std::string_view name) {
  if (name.substr(0, kByIdFolder.size()) == kByIdFolder) name.remove_prefix(kByIdFolder.size());
  if (name.empty() || name == "." || name == ".." || name.find('/') != std::string_view::npos) {
    return "expected a name in /dev/serial/by-id (the file name, or its full path)";
  }
  return std::nullopt;
}

std::string resolve_port(const PortSpec& spec, boost::system::error_code& error, std::string* message,
                         const PortRoots& roots) {
  error.clear();
  if (message != nullptr) message->clear();
  if (!spec.has_identity()) return spec.path;
  const std::vector<SerialPortInfo> ports = list_serial_ports(roots);
  std::vector<const SerialPortInfo*> found;
  for (const SerialPortInfo& port : ports) {
    if (!matches(port, spec)) continue;
    if (!spec.path.empty() && same_file_key(port.path) != same_file_key(spec.path)) continue;
    found.push_back(&port);
  }
  if (found.size() == 1) return found.front()->path;
  error = make_error_code(found.empty() ? TransportError::no_matching_port : TransportError::several_matching_ports);
  if (message != nullptr) {
    const bool none = found.empty();
    std::vector<const SerialPortInfo*> listed = found;
    if (none) {
      for (const SerialPortInfo& port : ports) listed.push_back(&port);
    }
    std::string text = (none ? "no serial port matches " : "several serial ports match ") + spec.describe();
    if (listed.empty()) {
      text += " (no serial ports found)";
    } else {
      text += none ? " (ports: " : " (";
      for (std::size_t i = 0; i < listed.size() && i < kListedCandidates; ++i) {
        text += (i == 0 ? "" : "; ") + listed[i]->describe();
      }
      if (listed.size() > kListedCandidates) text += " and " + std::to_string(listed.size() - kListedCandidates) + " more";
      text += ")";
    }
    *message = std::move(text);
  }
  return {};
}

}  // namespace tether::transports
