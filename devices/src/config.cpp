// Parsing and validation of rover configurations (schema: docs/config.md).
#include "tether/devices/config.hpp"

#include "builtin_codecs.hpp"
#include "tether/devices/json_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <array>
#include <cstddef>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>

namespace tether::devices {

// --- helpers ----------------------------------------------------------------------------------------------

namespace {

// The reader of json_reader.hpp under this file's short names.
using json = nlohmann::json;
using Node = JsonNode;
using Object = JsonObject;

[[noreturn]] void fail(const std::string& path, std::string detail) { fail_config(path, std::move(detail)); }
std::string join(const Names& names, std::string_view separator = ", ") { return join_names(names, separator); }
std::optional<std::string_view> closest(std::string_view word, const Names& candidates) {
  return closest_name(word, candidates);
}
bool contains(const Names& names, std::string_view name) { return contains_name(names, name); }

// --- transports -------------------------------------------------------------------------------------------

constexpr std::array<unsigned, 30> kStandardBauds = {50,     75,     110,    134,     150,     200,     300,    600,
                                                     1200,   1800,   2400,   4800,    9600,    19200,   38400,  57600,
                                                     115200, 230400, 460800, 500000,  576000,  921600,  1000000,
                                                     1152000, 1500000, 2000000, 2500000, 3000000, 3500000, 4000000};

unsigned default_baud(Codec codec) { return static_cast<unsigned>(codec_row(codec).default_baud); }

unsigned read_baud(const Node& node) {
  const auto baud = read_unsigned(node);
  if (std::find(kStandardBauds.begin(), kStandardBauds.end(), baud) == kStandardBauds.end()) {
    fail(node.path, "expected a standard baud rate (9600, 19200, 38400, 57600, 115200, 230400, ...), got " +
                        std::to_string(baud));
  }
  return static_cast<unsigned>(baud);
}

std::filesystem::path resolve_firmware(const Node& node, const ParseOptions& options) {
  const std::string text = read_nonempty_string(node);
  if (text.find('/') != std::string::npos) {
    std::filesystem::path path(text);
    if (path.is_relative() && !options.base_dir.empty()) path = options.base_dir / path;
    return path.lexically_normal();
  }
  if (options.firmware_dir.empty()) {
    fail(node.path, quote_json(text) +
                        " names a firmware image but no firmware folder was given (ParseOptions::firmware_dir); "
                        "give a path to the .elf file instead");
  }
  const bool has_suffix = text.size() > 4 && text.compare(text.size() - 4, 4, ".elf") == 0;
  return options.firmware_dir / (has_suffix ? text : text + ".elf");
}

transports::Pacing read_pacing(const Node& node) {
  return read_choice(node, "pacing", {"real_time", "fast"}) == 0 ? transports::Pacing::real_time
                                                                  : transports::Pacing::fast;
}

std::string read_usb_id(const Node& node) {
  const std::string text = read_string(node);
  if (const auto problem = transports::usb_id_problem(text)) fail(node.path, *problem + ", got " + show_json(node.value));
  return text;
}

// `"port": {"usb": {"vid": "2341", "pid": "0043", "serial": "..."}, "by_id": "usb-..."}`: at least one way.
void parse_port(const Node& node, SerialTransport& serial) {
  const Object object(node);
  object.allow_only({"usb", "by_id"});
  if (!object.has("usb") && !object.has("by_id")) node.expected("an object with \"usb\" or \"by_id\"");
  if (auto v = object.optional("usb")) {
    const Object usb(*v);
    usb.allow_only({"vid", "pid", "serial"});
    if (v->value.empty()) v->expected("an object with at least one of \"vid\", \"pid\", \"serial\"");
    if (auto id = usb.optional("vid")) serial.usb.vid = read_usb_id(*id);
    if (auto id = usb.optional("pid")) serial.usb.pid = read_usb_id(*id);
    if (auto text = usb.optional("serial")) {
      serial.usb.serial = read_nonempty_string(*text);
      if (std::any_of(serial.usb.serial.begin(), serial.usb.serial.end(),
                      [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; })) {
        fail(text->path, "must not contain control characters, got " + quote_json(serial.usb.serial));
      }
    }
  }
  if (auto v = object.optional("by_id")) {
    serial.by_id = read_string(*v);
    if (const auto problem = transports::by_id_problem(serial.by_id)) {
      fail(v->path, *problem + ", got " + show_json(v->value));
    }
  }
}

// `"reconnect": false`, `true`, or `{"max_attempts": N, "max_delay_ms": M}` (on, with limits).
void parse_reconnect(const Node& node, transports::ReconnectOptions& reconnect) {
  if (node.value.is_boolean()) {
    reconnect.enabled = read_bool(node);
    return;
  }
  if (!node.value.is_object()) node.expected("a boolean or an object");
  const Object object(node);
  object.allow_only({"max_attempts", "max_delay_ms"});
  reconnect.enabled = true;
  if (auto v = object.optional("max_attempts")) reconnect.max_attempts = static_cast<unsigned>(read_unsigned(*v, 0, 1000000));
  if (auto v = object.optional("max_delay_ms")) {
    reconnect.max_delay = std::chrono::milliseconds(read_unsigned(*v, 50, 60000));
  }
}

SerialTransport parse_serial(const Node& node, Codec codec) {
  const Object object(node);
  object.allow_only({"path", "port", "baud", "boot_wait_ms", "ready_banner", "boot_timeout_ms", "discard_boot_noise",
                     "low_latency", "exclusive", "hang_up_on_close", "reconnect", "boot"});
  SerialTransport serial;
  if (auto v = object.optional("port")) parse_port(*v, serial);
  if (auto v = object.optional("path"); v || (serial.usb.empty() && serial.by_id.empty())) {
    serial.path = read_nonempty_string(v ? *v : object.required("path"));
  }
  serial.options.baud = default_baud(codec);
  if (auto v = object.optional("baud")) serial.options.baud = read_baud(*v);
  if (auto v = object.optional("boot_wait_ms")) serial.options.boot_wait = std::chrono::milliseconds(read_ms(*v));
  // Detect by default where the codec knows its firmware's boot (codecs.hpp, CodecRow::boot): the
  // boot_wait is then the upper bound, reached only by a board that never says it booted.
  const CodecRow& row = codec_row(codec);
  serial.options.boot = row.boot.usable() ? transports::BootMode::detect : transports::BootMode::fixed;
  if (auto v = object.optional("boot")) {
    const std::string text = read_string(*v);
    const auto mode = transports::parse_boot_mode(text);
    if (!mode) fail(v->path, "expected \"detect\", \"fixed\" or \"none\", got " + quote_json(text));
    if (*mode == transports::BootMode::detect && !row.boot.usable()) {
      fail(v->path, "codec " + std::string(row.name) +
                        "'s firmware announces nothing at boot and has no probe: use \"fixed\" (boot_wait_ms)");
    }
    serial.options.boot = *mode;
  }
  if (auto v = object.optional("ready_banner")) serial.options.ready_banner = read_string(*v);
  if (auto v = object.optional("boot_timeout_ms")) {
    serial.options.boot_timeout = std::chrono::milliseconds(read_ms(*v, 1));
  }
  if (auto v = object.optional("discard_boot_noise")) serial.options.discard_boot_noise = read_bool(*v);
  if (auto v = object.optional("low_latency")) serial.options.low_latency = read_bool(*v);
  if (auto v = object.optional("exclusive")) serial.options.exclusive = read_bool(*v);
  if (auto v = object.optional("hang_up_on_close")) serial.options.hang_up_on_close = read_bool(*v);
  if (auto v = object.optional("reconnect")) parse_reconnect(*v, serial.options.reconnect);
  return serial;
}

TcpTransport parse_tcp(const Node& node) {
  const Object object(node);
  object.allow_only({"host", "port", "connect_timeout_ms"});
  TcpTransport tcp;
  tcp.host = read_nonempty_string(object.required("host"));
  tcp.port = static_cast<std::uint16_t>(read_unsigned(object.required("port"), 1, 65535));
  if (auto v = object.optional("connect_timeout_ms")) tcp.connect_timeout = std::chrono::milliseconds(read_ms(*v, 1));
  return tcp;
}

transports::FaultConfig parse_faults(const Node& node) {
  const Object object(node);
  object.allow_only({"bit_error_rate", "drop_rate", "duplicate_rate", "latency_us", "latency_jitter_us"});
  transports::FaultConfig faults;
  if (auto v = object.optional("bit_error_rate")) faults.bit_error_rate = read_rate(*v);
  if (auto v = object.optional("drop_rate")) faults.drop_rate = read_rate(*v);
  if (auto v = object.optional("duplicate_rate")) faults.duplicate_rate = read_rate(*v);
  constexpr std::uint64_t kMaxMicros = 3'600'000'000ull;  // an hour: anything more is a typo
  if (auto v = object.optional("latency_us")) {
    faults.latency = std::chrono::microseconds(static_cast<std::int64_t>(read_unsigned(*v, 0, kMaxMicros)));
  }
  if (auto v = object.optional("latency_jitter_us")) {
    faults.latency_jitter = std::chrono::microseconds(static_cast<std::int64_t>(read_unsigned(*v, 0, kMaxMicros)));
  }
  return faults;
}

VirtualTransport parse_virtual(const Node& node, const std::string& device_name, const ParseOptions& options) {
  const Object object(node);
  object.allow_only({"firmware", "pacing", "seed", "faults"});
  VirtualTransport virt;
  virt.board.firmware = resolve_firmware(object.required("firmware"), options);
  virt.board.name = device_name;
  if (auto v = object.optional("pacing")) virt.board.pacing = read_pacing(*v);
  if (auto v = object.optional("seed")) virt.board.seed = read_unsigned(*v);
  if (auto v = object.optional("faults")) {
    const Object faults(*v);
    faults.allow_only({"to_mcu", "from_mcu"});
    if (auto f = faults.optional("to_mcu")) virt.board.to_mcu_faults = parse_faults(*f);
    if (auto f = faults.optional("from_mcu")) virt.board.from_mcu_faults = parse_faults(*f);
  }
  return virt;
}

constexpr std::size_t kEepromBytes = 1024;  // ATmega328P

// A ring board's `eeprom` settings object, read by the codec's row once the device's options are parsed.
struct PendingBoardSettings {
  std::size_t board = 0;
  Node settings;
};

RingBoardConfig parse_ring_board(const Node& node, std::size_t index, const CodecRow& row, const ParseOptions& options,
                                 std::vector<PendingBoardSettings>& pending) {
  const Object object(node);
  object.allow_only({"firmware", "eeprom"});
  RingBoardConfig board;
  if (auto v = object.optional("firmware")) {
    board.firmware = resolve_firmware(*v, options);
  } else if (!row.ring_board_image.empty()) {
    board.firmware = resolve_firmware(Node{json(row.ring_board_image), object.path() + ".firmware"}, options);
  } else {
    board.firmware = resolve_firmware(object.required("firmware"), options);
  }
  if (auto v = object.optional("eeprom")) {
    if (v->value.is_array()) {
      if (v->value.size() > kEepromBytes) {
        fail(v->path, "expected at most " + std::to_string(kEepromBytes) + " bytes, got " +
                          std::to_string(v->value.size()));
      }
      for_each_element(*v, [&](const Node& element, std::size_t) {
        board.eeprom.push_back(static_cast<std::uint8_t>(read_unsigned(element, 0, 255)));
      });
    } else if (v->value.is_object() && row.ring_board_settings) {
      pending.push_back(PendingBoardSettings{index, *v});
    } else {
      v->expected(row.ring_board_settings ? "an array of bytes or an object of node settings" : "an array of bytes");
    }
  }
  return board;
}

VirtualRingTransport parse_virtual_ring(const Node& node, const CodecRow& row, const ParseOptions& options,
                                        std::vector<PendingBoardSettings>& pending) {
  const Object object(node);
  object.allow_only({"boards", "pacing", "seed"});
  VirtualRingTransport ring;
  const Node boards = object.required("boards");
  if (!boards.value.is_array() || boards.value.empty()) boards.expected("a non-empty array of boards");
  for_each_element(boards, [&](const Node& board, std::size_t i) {
    ring.boards.push_back(parse_ring_board(board, i, row, options, pending));
  });
  if (auto v = object.optional("pacing")) ring.pacing = read_pacing(*v);
  if (auto v = object.optional("seed")) ring.seed = read_unsigned(*v);
  return ring;
}

// The settings objects of a ring's boards into their EEPROM, by the codec's row, with the device's options.
void encode_board_settings(const std::vector<PendingBoardSettings>& pending, const CodecRow& row,
                           DeviceConfig& device) {
  auto& ring = std::get<VirtualRingTransport>(device.transport);
  for (const PendingBoardSettings& each : pending) {
    std::vector<std::uint8_t> bytes = row.ring_board_settings(RingBoardContext{each.settings, each.board, &device.options});
    if (bytes.size() > kEepromBytes) {
      fail(each.settings.path, "the settings make " + std::to_string(bytes.size()) + " bytes of EEPROM (at most " +
                                   std::to_string(kEepromBytes) + ")");
    }
    ring.boards[each.board].eeprom = std::move(bytes);
  }
}

const Names kTransports = {"serial", "tcp", "virtual", "virtual_ring"};

// The codecs a virtual ring carries: `elcano`.
std::string ring_codecs() {
  Names names;
  for (const CodecRow* row : codec_rows()) {
    if (row->virtual_boards == VirtualBoards::ring) names.push_back(row->name);
  }
  return join(names, " or ");
}

TransportConfig parse_transport(const Node& node, Codec codec, const std::string& device_name,
                                const ParseOptions& options, std::vector<PendingBoardSettings>& pending) {
  const Object object(node);
  const json& value = node.value;
  if (value.empty()) {
    fail(node.path, "expected an object with one of the keys " + join(kTransports) + ", got an empty object");
  }
  for (const auto& item : value.items()) {
    if (!contains(kTransports, item.key())) {
      std::string detail = "unknown transport " + quote_json(item.key()) + " (expected one of " + join(kTransports) + ")";
      if (const auto near = closest(item.key(), kTransports)) detail += "; did you mean " + quote_json(*near) + "?";
      fail(node.path, detail);
    }
  }
  if (value.size() > 1) {
    std::string keys;
    for (const auto& item : value.items()) keys += (keys.empty() ? "" : " and ") + quote_json(item.key());
    fail(node.path, "expected exactly one transport, got " + keys);
  }
  const std::string kind = value.begin().key();
  const Node inner = node.key(kind);
  const bool on_ring = codec_row(codec).virtual_boards == VirtualBoards::ring;
  if (kind == "virtual_ring" && !on_ring) {
    fail(inner.path, "a virtual ring carries codec " + ring_codecs() + " only, not " + std::string(to_string(codec)) +
                         " (use \"virtual\" for one board)");
  }
  if (kind == "virtual" && on_ring) {
    fail(inner.path, "codec " + std::string(to_string(codec)) +
                         " runs on a ring: use \"virtual_ring\" (a ring may have one board)");
  }
  if (kind == "serial") return parse_serial(inner, codec);
  if (kind == "tcp") return parse_tcp(inner);
  if (kind == "virtual") return parse_virtual(inner, device_name, options);
  return parse_virtual_ring(inner, codec_row(codec), options, pending);
}

// --- codec options --------------------------------------------------------------------------------------

// For a codec: keys that belong to other codecs only -> "does not apply to codec X (an option of Y)".
std::map<std::string, std::string> foreign_keys(const CodecRow& codec) {
  std::map<std::string, std::string> owners;
  for (const CodecRow* other : codec_rows()) {
    if (other == &codec) continue;
    for (std::string_view key : other->option_keys) {
      if (contains(codec.option_keys, key)) continue;
      auto& text = owners[std::string(key)];
      text += text.empty() ? "of " : ", ";
      text += other->name;
    }
  }
  for (auto& [key, text] : owners) {
    text = "does not apply to codec " + std::string(codec.name) + " (it is an option " + text + ")";
  }
  return owners;
}

CodecOptions parse_options(const std::optional<Node>& node, const std::string& path, Codec codec,
                           const TransportConfig& transport, const std::filesystem::path& base_dir) {
  const CodecRow& row = codec_row(codec);
  OptionsContext context;
  context.path = path;
  context.codec = codec;
  context.transport = &transport;
  context.base_dir = base_dir;
  if (node) {
    Object(*node).allow_only(row.option_keys, foreign_keys(row));
    context.options = &node->value;
  }
  return row.parse_options(context);
}

Names codec_names() {
  Names names;
  for (const CodecRow* row : codec_rows()) names.push_back(row->name);
  return names;
}

// `"record": "FILE"` or `{"file": ..., "max_bytes", "max_seconds", "files", "overwrite"}`: a capture file,
// relative to the configuration's folder like every file it names.
transports::RecordOptions parse_record(const Node& node, const ParseOptions& options) {
  transports::RecordOptions record;
  const auto resolve = [&](const std::string& file) {
    const std::filesystem::path path(file);
    return path.is_relative() && !options.base_dir.empty() ? (options.base_dir / path).lexically_normal() : path;
  };
  if (node.value.is_string()) {
    record.file = resolve(read_nonempty_string(node));
    return record;
  }
  if (!node.value.is_object()) node.expected("a capture file name or an object with \"file\"");
  const Object object(node);
  object.allow_only({"file", "max_bytes", "max_seconds", "files", "overwrite"});
  record.file = resolve(read_nonempty_string(object.required("file")));
  if (auto v = object.optional("max_bytes")) record.max_file_bytes = read_unsigned(*v, 4096);
  if (auto v = object.optional("max_seconds")) {
    record.max_file_duration = std::chrono::milliseconds(read_unsigned(*v, 1, 366u * 24 * 3600) * 1000);
  }
  if (auto v = object.optional("files")) record.ring_files = static_cast<unsigned>(read_unsigned(*v, 2, 1000));
  if (auto v = object.optional("overwrite")) record.overwrite = read_bool(*v);
  return record;
}

DeviceConfig parse_device(const Node& node, const ParseOptions& options) {
  const Object object(node);
  object.allow_only({"name", "codec", "transport", "options", "record"});
  DeviceConfig device;
  device.name = read_nonempty_string(object.required("name"));
  const std::vector<const CodecRow*> rows = codec_rows();
  device.codec = rows.at(read_choice(object.required("codec"), "codec", codec_names()))->codec;
  std::vector<PendingBoardSettings> pending;
  device.transport = parse_transport(object.required("transport"), device.codec, device.name, options, pending);
  device.options = parse_options(object.optional("options"), object.path() + ".options", device.codec, device.transport,
                                 options.base_dir);
  if (!pending.empty()) encode_board_settings(pending, codec_row(device.codec), device);
  if (auto v = object.optional("record")) device.record = parse_record(*v, options);
  return device;
}

// --- validation of typed configurations ----------------------------------------------------------------------

std::string device_path(std::size_t i) { return "devices[" + std::to_string(i) + "]"; }

std::string transport_key(const TransportConfig& transport) {
  return std::string(*(kTransports.begin() + static_cast<std::ptrdiff_t>(transport.index())));
}

void validate_device(const DeviceConfig& device, std::size_t i) {
  const std::string path = device_path(i);
  const std::string transport_path = path + ".transport." + transport_key(device.transport);
  const CodecRow* found = nullptr;
  for (const CodecRow* each : codec_rows()) {
    if (each->codec == device.codec) found = each;
  }
  if (found == nullptr) {
    fail(path + ".codec", "no codec has the value " + std::to_string(static_cast<unsigned>(device.codec)) +
                              " (register_codec, codecs.hpp)");
  }
  const CodecRow& row = *found;
  const bool ring = std::holds_alternative<VirtualRingTransport>(device.transport);
  const bool single_board = std::holds_alternative<VirtualTransport>(device.transport);
  const bool on_ring = row.virtual_boards == VirtualBoards::ring;
  if (ring && !on_ring) {
    fail(transport_path, "a virtual ring carries codec " + ring_codecs() + " only, not " + std::string(row.name));
  }
  if (single_board && on_ring) fail(transport_path, "codec " + std::string(row.name) + " runs on a ring");
  if (const auto* serial = std::get_if<SerialTransport>(&device.transport)) {
    const bool identity = serial->port().has_identity();
    if (serial->path.empty() && !identity) fail(transport_path + ".path", "must not be empty (or name the board by \"port\")");
    for (const auto& [id, key] : {std::pair{&serial->usb.vid, "vid"}, std::pair{&serial->usb.pid, "pid"}}) {
      if (id->empty()) continue;
      if (const auto problem = transports::usb_id_problem(*id)) {
        fail(transport_path + ".port.usb." + key, *problem + ", got " + quote_json(*id));
      }
    }
    if (!serial->by_id.empty()) {
      if (const auto problem = transports::by_id_problem(serial->by_id)) {
        fail(transport_path + ".port.by_id", *problem + ", got " + quote_json(serial->by_id));
      }
    }
  }
  if (const auto* tcp = std::get_if<TcpTransport>(&device.transport)) {
    if (tcp->host.empty()) fail(transport_path + ".host", "must not be empty");
    if (tcp->port == 0) fail(transport_path + ".port", "must be in 1..65535");
  }
  if (const auto* rings = std::get_if<VirtualRingTransport>(&device.transport); rings && rings->boards.empty()) {
    fail(transport_path + ".boards", "a ring needs at least one board");
  }
  if (row.validate) row.validate(device.options, path + ".options");
}

}  // namespace

// --- the built-in codecs' options (rows in codec_table.cpp) ---------------------------------------------------

// --- helpers of codec rows (codecs.hpp) ----------------------------------------------------------------------

void read_call_timing(const JsonObject& object, session::CallTiming& timing) {
  if (auto v = object.optional("attempt_timeout_ms")) timing.attempt_timeout = read_ms(*v, 1);
  if (auto v = object.optional("call_budget_ms")) timing.call_budget = read_ms(*v, 1);
  if (auto v = object.optional("max_attempts")) timing.max_attempts = static_cast<std::uint8_t>(read_unsigned(*v, 1, 255));
}

void check_call_timing(const std::string& options_path, const session::CallTiming& timing) {
  if (timing.attempt_timeout == 0) fail(options_path + ".attempt_timeout_ms", "must be at least 1");
  if (timing.call_budget == 0) fail(options_path + ".call_budget_ms", "must be at least 1");
  if (timing.max_attempts == 0) fail(options_path + ".max_attempts", "must be at least 1");
}

namespace detail {

}  // namespace detail

// --- public API ---------------------------------------------------------------------------------------------

void validate(const RoverConfig& config) {
  if (config.devices.empty()) fail("devices", "expected at least one device");
  std::map<std::string, std::size_t, std::less<>> names;
  for (std::size_t i = 0; i < config.devices.size(); ++i) {
    const DeviceConfig& device = config.devices[i];
    if (device.name.empty()) fail(device_path(i) + ".name", "must not be empty");
    // A name is typed after --device and printed in messages: a NUL or a control character in it would
    // cut or garble them.
    if (std::any_of(device.name.begin(), device.name.end(),
                    [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; })) {
      fail(device_path(i) + ".name", "must not contain control characters, got " + quote_json(device.name));
    }
    const auto [where, inserted] = names.emplace(device.name, i);
    if (!inserted) {
      fail(device_path(i) + ".name",
           "duplicate device name " + quote_json(device.name) + " (also " + device_path(where->second) + ")");
    }
    validate_device(device, i);
  }
}

RoverConfig parse_document(const nlohmann::json& document, const ParseOptions& options) {
  if (!document.is_object()) fail("", "expected a JSON object at the top level, got " + show_json(document));
  const Object root(Node{document, ""});
  root.allow_only({"name", "devices", "record"});
  RoverConfig config;
  if (auto v = root.optional("name")) config.name = read_string(*v);
  if (auto v = root.optional("record")) config.record = parse_record(*v, options);
  const Node devices = root.required("devices");
  if (!devices.value.is_array() || devices.value.empty()) devices.expected("a non-empty array of devices");
  std::map<std::string, std::size_t, std::less<>> names;
  for_each_element(devices, [&](const Node& element, std::size_t i) {
    DeviceConfig device = parse_device(element, options);
    const auto [where, inserted] = names.emplace(device.name, i);
    if (!inserted) {
      fail(element.path + ".name",
           "duplicate device name " + quote_json(device.name) + " (also " + device_path(where->second) + ")");
    }
    config.devices.push_back(std::move(device));
  });
  validate(config);
  return config;
}

void NameList::add(std::string_view name) {
  if (count_++ < kListed) listed_ += (listed_.empty() ? "" : ", ") + quote_json(name);
}

std::string NameList::text() const {
  return count_ > kListed ? listed_ + " and " + std::to_string(count_ - kListed) + " more" : listed_;
}

namespace {

// `size`: "2000000", or "more than 1048576" when the rest was not read.
std::string too_large(const std::string& size) {
  return "configuration too large: " + size + " bytes (at most " + std::to_string(kMaxConfigBytes) + ")";
}

// Rejects a key given twice in one object (nlohmann keeps the last silently), naming its JSON path in the
// style of the other errors (`devices[1].options.baud`), and nesting deeper than kMaxConfigDepth. A SAX pass
// over the text (nlohmann's callback parser would do it in one, but it scans the parent array at every
// object's end: quadratic in devices), keeping one frame per open object or array with only its own key or
// index: a path is built only for an error, so the pass is linear in the text.
class StructureCheck final : public nlohmann::json_sax<json> {
 public:
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return open(false); }
  bool start_array(std::size_t) override { return open(true); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& key) override {
    Frame& object = frames_.back();
    object.key = key;
    if (!object.keys.insert(key).second && !duplicate_) {
      duplicate_ = ConfigError(path(), "duplicate key (the object has it already)");
    }
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;  // the document parse that follows reports it, with its line and column
  }

  /// The first duplicate key, if any.
  const std::optional<ConfigError>& duplicate() const { return duplicate_; }

 private:
  struct Frame {
    bool array = false;
    std::size_t index = 0;  // arrays: the next element's
    std::string key;        // objects: the current key
    std::set<std::string> keys;
  };
  // The path of the value about to be read.
  std::string path() const {
    std::string text;
    for (const Frame& frame : frames_) {
      if (frame.array) {
        // Appended piece by piece: g++ 12 at -O3 warns (-Wrestrict, a false positive) on "[" + to_string().
        text += '[';
        text += std::to_string(frame.index);
        text += ']';
      } else {
        if (!text.empty()) text += ".";
        text += frame.key;
      }
    }
    return text;
  }
  bool open(bool array) {
    if (frames_.size() == kMaxConfigDepth) {
      fail(path(), "nested too deeply (at most " + std::to_string(kMaxConfigDepth) + " levels of objects and arrays)");
    }
    frames_.push_back(Frame{array, 0, {}, {}});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return value();
  }
  bool value() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    return true;
  }

  std::vector<Frame> frames_;
  std::optional<ConfigError> duplicate_;
};

}  // namespace

// JSON text (comments allowed) into a document; ConfigError "invalid JSON: parse error at line L, column C: ...",
// "configuration too large", nesting too deep, or a duplicate key with its path.
json parse_json_text(std::string_view json_text) {
  if (json_text.size() > kMaxConfigBytes) fail("", too_large(std::to_string(json_text.size())));
  // Structure first: a deeply nested text is refused before a document is built for it.
  StructureCheck structure;
  const bool well_formed = json::sax_parse(json_text.begin(), json_text.end(), &structure,
                                           nlohmann::json::input_format_t::json, /*strict=*/true,
                                           /*ignore_comments=*/true);
  json document;
  try {
    document = json::parse(json_text.begin(), json_text.end(), nullptr, /*allow_exceptions=*/true,
                           /*ignore_comments=*/true);
  } catch (const json::exception& error) {  // parse_error, and out_of_range for a number too large for a double
    std::string text = error.what();
    // Drop nlohmann's "[json.exception.parse_error.101] " prefix; keep "parse error at line L, column C: ...".
    if (const auto end = text.find("] "); text.rfind("[json.exception.", 0) == 0 && end != std::string::npos) {
      text = text.substr(end + 2);
    }
    throw ConfigError("", "invalid JSON: " + text);
  }
  if (well_formed && structure.duplicate()) throw *structure.duplicate();
  return document;
}

RoverConfig parse_config(std::string_view json_text, const ParseOptions& options) {
  return parse_document(parse_json_text(json_text), options);
}

RoverConfig load_config(const std::filesystem::path& file, ParseOptions options) {
  const auto os_error = [&](int error) {
    return ConfigError("", std::system_category().message(error), error_code(error, boost::system::system_category()),
                       file.string());
  };
  std::error_code status_error;
  if (std::filesystem::is_directory(file, status_error)) throw os_error(EISDIR);  // ifstream opens one, reads nothing
  std::ifstream stream(file, std::ios::binary);
  if (!stream) {
    const int error = errno;
    throw os_error(error != 0 ? error : ENOENT);
  }
  std::string text(kMaxConfigBytes + 1, '\0');  // one byte more than allowed tells a file too large
  stream.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(stream.gcount()));
  if (stream.bad()) throw os_error(EIO);
  if (options.base_dir.empty()) options.base_dir = file.parent_path();
  try {
    if (text.size() > kMaxConfigBytes) {
      std::error_code size_error;
      const std::uintmax_t size = std::filesystem::is_regular_file(file, size_error)
                                      ? std::filesystem::file_size(file, size_error)
                                      : std::uintmax_t{0};
      fail("", too_large(size > kMaxConfigBytes && !size_error ? std::to_string(size)
                                                               : "more than " + std::to_string(kMaxConfigBytes)));
    }
    return parse_config(text, options);
  } catch (const ConfigError& error) {
    throw ConfigError(error.path(), error.detail(), error.code(), file.string());
  }
}

// --- descriptions -----------------------------------------------------------------------------------------------

namespace {

const char* pacing_name(transports::Pacing pacing) {
  return pacing == transports::Pacing::fast ? "fast" : "real_time";
}

}  // namespace

std::string describe(const TransportConfig& transport) {
  if (const auto* serial = std::get_if<SerialTransport>(&transport)) {
    return "serial " + serial->port().describe() + " " + std::to_string(serial->options.baud);
  }
  if (const auto* tcp = std::get_if<TcpTransport>(&transport)) {
    return "tcp " + tcp->host + ":" + std::to_string(tcp->port);
  }
  if (const auto* virt = std::get_if<VirtualTransport>(&transport)) {
    std::string text = "virtual " + virt->board.firmware.filename().string() + " (" + pacing_name(virt->board.pacing) +
                       ", seed " + std::to_string(virt->board.seed);
    if (virt->board.to_mcu_faults.active()) text += ", to_mcu " + virt->board.to_mcu_faults.describe();
    if (virt->board.from_mcu_faults.active()) text += ", from_mcu " + virt->board.from_mcu_faults.describe();
    return text + ")";
  }
  const auto& ring = std::get<VirtualRingTransport>(transport);
  std::set<std::string> images;
  for (const auto& board : ring.boards) images.insert(board.firmware.filename().string());
  std::string list;
  for (const auto& image : images) list += (list.empty() ? "" : ", ") + image;
  return "virtual ring of " + std::to_string(ring.boards.size()) + (ring.boards.size() == 1 ? " board (" : " boards (") +
         list + "; " + pacing_name(ring.pacing) + ")";
}

}  // namespace tether::devices
