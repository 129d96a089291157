// Parsing and validation of rover configurations (schema: docs/config.md).
#include "tether/devices/config.hpp"

#include "builtin_codecs.hpp"
#include "tether/elcano/node/config.hpp"

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

namespace tether::devices {

// --- error category -------------------------------------------------------------------------------------

namespace {

class DevicesCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.devices"; }
  std::string message(int value) const override {
    switch (static_cast<DevicesError>(value)) {
      case DevicesError::invalid_config: return "invalid configuration";
      case DevicesError::unknown_device: return "no device of that name";
      case DevicesError::wrong_codec: return "the device speaks another codec";
      case DevicesError::not_supported: return "not supported by this build";
      case DevicesError::device_not_ready: return "the device did not answer its handshake in time";
    }
    return "unknown tether.devices error";
  }
};

std::string compose(const std::string& file, const std::string& path, const std::string& detail) {
  std::string text;
  if (!file.empty()) text += file + ": ";
  if (!path.empty()) text += path + ": ";
  return text + detail;
}

}  // namespace

const boost::system::error_category& devices_category() {
  static const DevicesCategory category;
  return category;
}

error_code make_error_code(DevicesError error) { return error_code(static_cast<int>(error), devices_category()); }

ConfigError::ConfigError(std::string path, std::string detail, error_code code, std::string file)
    : std::runtime_error(compose(file, path, detail)),
      path_(std::move(path)),
      detail_(std::move(detail)),
      code_(code),
      file_(std::move(file)) {}

std::string_view to_string(Codec codec) {
  try {
    return codec_row(codec).name;
  } catch (const std::out_of_range&) {
    return "unknown";
  }
}

// --- helpers ----------------------------------------------------------------------------------------------

namespace {

using json = nlohmann::json;
using Names = std::vector<std::string_view>;

[[noreturn]] void fail(const std::string& path, std::string detail) { throw ConfigError(path, std::move(detail)); }

// `text` as a JSON string literal (quotes, escapes).
std::string quote_json(std::string_view text) { return json(std::string(text)).dump(); }

// How a value is shown after "got": `string "fast"`, `number -3`, `boolean true`, `null`, `object`, `array`.
std::string show(const json& value) {
  switch (value.type()) {
    case json::value_t::string: return "string " + value.dump();
    case json::value_t::boolean: return std::string("boolean ") + (value.get<bool>() ? "true" : "false");
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "number " + value.dump();
    case json::value_t::null: return "null";
    case json::value_t::object: return value.empty() ? "an empty object" : "object";
    case json::value_t::array: return value.empty() ? "an empty array" : "array";
    default: return "an invalid value";
  }
}

std::string join(const Names& names, std::string_view separator = ", ") {
  std::string text;
  for (std::string_view name : names) {
    if (!text.empty()) text += separator;
    text += name;
  }
  return text;
}

// Optimal string alignment distance (Levenshtein plus adjacent transpositions).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1, 0));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// The closest candidate when it is plausibly a typo of `word`.
std::optional<std::string_view> closest(std::string_view word, const Names& candidates) {
  std::optional<std::string_view> best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view candidate : candidates) {
    const std::size_t distance = edit_distance(word, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  if (!best) return std::nullopt;
  const std::size_t limit = std::max<std::size_t>(1, std::min<std::size_t>(3, best->size() / 3));
  if (best_distance > limit) return std::nullopt;
  return best;
}

bool contains(const Names& names, std::string_view name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

// A JSON value and its path.
struct Node {
  const json& value;
  std::string path;

  Node key(std::string_view name) const {
    return Node{value.at(std::string(name)), path.empty() ? std::string(name) : path + "." + std::string(name)};
  }
  Node index(std::size_t i) const { return Node{value.at(i), path + "[" + std::to_string(i) + "]"}; }
  [[noreturn]] void expected(std::string_view what) const {
    fail(path, "expected " + std::string(what) + ", got " + show(value));
  }
};

// An object node: key checks and member access.
class Object {
 public:
  explicit Object(const Node& node) : node_(node) {
    if (!node.value.is_object()) node.expected("an object");
  }
  const Node& node() const { return node_; }
  const std::string& path() const { return node_.path; }

  // Every key must be in `allowed`; `elsewhere` (key -> what it belongs to) explains keys of other codecs.
  void allow_only(const Names& allowed, const std::map<std::string, std::string>& elsewhere = {}) const {
    for (const auto& item : node_.value.items()) {
      const std::string& key = item.key();
      if (contains(allowed, key)) continue;
      if (const auto other = elsewhere.find(key); other != elsewhere.end()) {
        fail(path(), "key " + quote_json(key) + " " + other->second);
      }
      if (const auto near = closest(key, allowed)) {
        fail(path(), "unknown key " + quote_json(key) + " (did you mean " + quote_json(*near) + "?)");
      }
      fail(path(), "unknown key " + quote_json(key) + " (allowed: " + join(allowed) + ")");
    }
  }
  bool has(std::string_view key) const { return node_.value.contains(std::string(key)); }
  std::optional<Node> optional(std::string_view key) const {
    if (!has(key)) return std::nullopt;
    return node_.key(key);
  }
  Node required(std::string_view key) const {
    if (!has(key)) fail(path(), "missing key " + quote_json(key));
    return node_.key(key);
  }

 private:
  Node node_;
};

std::uint64_t read_unsigned(const Node& node, std::uint64_t min = 0,
                            std::uint64_t max = std::numeric_limits<std::uint64_t>::max()) {
  const json& value = node.value;
  // Parsed text stores non-negative integers as unsigned; documents built in code may hold them signed.
  const bool unsigned_integer =
      value.is_number_unsigned() || (value.is_number_integer() && value.get<std::int64_t>() >= 0);
  if (!unsigned_integer) node.expected("an unsigned integer");
  const auto number = value.get<std::uint64_t>();
  if (number < min || number > max) {
    fail(node.path, "expected an unsigned integer in " + std::to_string(min) + ".." + std::to_string(max) + ", got " +
                        std::to_string(number));
  }
  return number;
}

// A duration in milliseconds: 0 (or `min`) .. 2^31 - 1 (the engine's deadlines stay comparable).
Duration read_ms(const Node& node, Duration min = 0) {
  return static_cast<Duration>(read_unsigned(node, min, 0x7FFFFFFFu));
}

bool read_bool(const Node& node) {
  if (!node.value.is_boolean()) node.expected("a boolean");
  return node.value.get<bool>();
}

std::string read_string(const Node& node) {
  if (!node.value.is_string()) node.expected("a string");
  return node.value.get<std::string>();
}

std::string read_nonempty_string(const Node& node) {
  if (!node.value.is_string() || node.value.get_ref<const std::string&>().empty()) node.expected("a non-empty string");
  return node.value.get<std::string>();
}

double read_rate(const Node& node) {
  if (!node.value.is_number()) node.expected("a number in [0, 1]");
  const double rate = node.value.get<double>();
  if (!(rate >= 0.0 && rate <= 1.0)) node.expected("a number in [0, 1]");
  return rate;
}

// One of `names` (returns its index); `what` names the kind of value in the message ("codec").
std::size_t read_choice(const Node& node, std::string_view what, const Names& names) {
  if (!node.value.is_string()) {
    node.expected("a " + std::string(what) + " name (one of " + join(names) + ")");
  }
  const auto& text = node.value.get_ref<const std::string&>();
  std::size_t i = 0;
  for (std::string_view name : names) {
    if (name == text) return i;
    ++i;
  }
  std::string detail = "unknown " + std::string(what) + " " + quote_json(text) + " (expected one of " + join(names) + ")";
  if (const auto near = closest(text, names)) detail += "; did you mean " + quote_json(*near) + "?";
  fail(node.path, detail);
}

template <typename Visit>
void for_each_element(const Node& node, Visit visit) {
  for (std::size_t i = 0; i < node.value.size(); ++i) visit(node.index(i), i);
}

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

SerialTransport parse_serial(const Node& node, Codec codec) {
  const Object object(node);
  object.allow_only({"path", "baud", "boot_wait_ms", "ready_banner", "boot_timeout_ms", "discard_boot_noise",
                     "low_latency", "exclusive", "hang_up_on_close"});
  SerialTransport serial;
  serial.path = read_nonempty_string(object.required("path"));
  serial.options.baud = default_baud(codec);
  if (auto v = object.optional("baud")) serial.options.baud = read_baud(*v);
  if (auto v = object.optional("boot_wait_ms")) serial.options.boot_wait = std::chrono::milliseconds(read_ms(*v));
  if (auto v = object.optional("ready_banner")) serial.options.ready_banner = read_string(*v);
  if (auto v = object.optional("boot_timeout_ms")) {
    serial.options.boot_timeout = std::chrono::milliseconds(read_ms(*v, 1));
  }
  if (auto v = object.optional("discard_boot_noise")) serial.options.discard_boot_noise = read_bool(*v);
  if (auto v = object.optional("low_latency")) serial.options.low_latency = read_bool(*v);
  if (auto v = object.optional("exclusive")) serial.options.exclusive = read_bool(*v);
  if (auto v = object.optional("hang_up_on_close")) serial.options.hang_up_on_close = read_bool(*v);
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

// The codec's names (elcano::to_string), in the order of kElcanoTypeValues.
constexpr std::array<elcano::Type, 4> kElcanoTypeValues = {elcano::Type::drive, elcano::Type::sensor,
                                                           elcano::Type::goal, elcano::Type::segment};
const Names kElcanoTypes = {elcano::to_string(elcano::Type::drive), elcano::to_string(elcano::Type::sensor),
                            elcano::to_string(elcano::Type::goal), elcano::to_string(elcano::Type::segment)};

elcano::TypeSet read_types(const Node& node) {
  if (!node.value.is_array()) node.expected("an array of message types (" + join(kElcanoTypes) + ")");
  elcano::TypeSet set;
  for_each_element(node, [&](const Node& element, std::size_t) {
    const elcano::Type type = kElcanoTypeValues.at(read_choice(element, "message type", kElcanoTypes));
    if (set.contains(type)) fail(element.path, "message type " + element.value.dump() + " is listed twice");
    set = set.with(type);
  });
  return set;
}

constexpr std::size_t kEepromBytes = 1024;  // ATmega328P

// Behaviour names, bit i = 1 << i (the elcano-node image's k* behaviour bits).
const Names kBehaviours = {"answer_goal_with_segment", "answer_segment_with_drive", "answer_sensor_with_drive",
                               "drive_servos", "report_drive_as_sensor"};

// An elcano-node's settings object (`boards[i].eeprom`); a node file (`with_link`) also has the ring's
// `generation` and `baud`, which its caller reads.
RingNodeSettings parse_node_settings(const Node& node, bool with_link, std::uint8_t default_node_number) {
  const Object settings(node);
  if (with_link) {
    settings.allow_only({"capture", "behaviours", "next_receiver_buffer", "next_poll_interval_ms", "loop_period_ms",
                         "node_number", "generation", "baud"});
  } else {
    settings.allow_only({"capture", "behaviours", "next_receiver_buffer", "next_poll_interval_ms", "loop_period_ms",
                         "node_number"});
  }
  RingNodeSettings node_settings;
  node_settings.node_number = default_node_number;
  if (auto c = settings.optional("capture")) node_settings.capture = read_types(*c);
  if (auto b = settings.optional("behaviours")) {
    if (!b->value.is_array()) b->expected("an array of behaviours (" + join(kBehaviours) + ")");
    for_each_element(*b, [&](const Node& element, std::size_t) {
      const auto bit = static_cast<std::uint8_t>(1u << read_choice(element, "behaviour", kBehaviours));
      if ((node_settings.behaviour_bits & bit) != 0) {
        fail(element.path, "behaviour " + element.value.dump() + " is listed twice");
      }
      node_settings.behaviour_bits = static_cast<std::uint8_t>(node_settings.behaviour_bits | bit);
    });
  }
  if (auto n = settings.optional("next_receiver_buffer")) {
    node_settings.next_receiver_buffer = static_cast<std::uint16_t>(read_unsigned(*n, 2, 65535));
  }
  if (auto n = settings.optional("next_poll_interval_ms")) {
    node_settings.next_poll_interval = static_cast<std::uint16_t>(read_unsigned(*n, 0, 65535));
  }
  if (auto n = settings.optional("loop_period_ms")) {
    node_settings.loop_period = static_cast<std::uint16_t>(read_unsigned(*n, 0, 65535));
  }
  if (auto n = settings.optional("node_number")) {
    node_settings.node_number = static_cast<std::uint8_t>(read_unsigned(*n, 0, 255));
  }
  return node_settings;
}

RingBoardConfig parse_ring_board(const Node& node, std::size_t index, const ParseOptions& options) {
  const Object object(node);
  object.allow_only({"firmware", "eeprom"});
  RingBoardConfig board;
  if (auto v = object.optional("firmware")) {
    board.firmware = resolve_firmware(*v, options);
  } else {
    board.firmware = resolve_firmware(Node{json("elcano-node"), object.path() + ".firmware"}, options);
  }
  if (auto v = object.optional("eeprom")) {
    if (v->value.is_array()) {
      if (v->value.size() > kEepromBytes) {
        fail(v->path, "expected at most " + std::to_string(kEepromBytes) + " bytes, got " +
                          std::to_string(v->value.size()));
      }
      std::vector<std::uint8_t> bytes;
      for_each_element(*v, [&](const Node& element, std::size_t) {
        bytes.push_back(static_cast<std::uint8_t>(read_unsigned(element, 0, 255)));
      });
      board.eeprom = std::move(bytes);
    } else if (v->value.is_object()) {
      board.eeprom = parse_node_settings(*v, false, static_cast<std::uint8_t>(index));
    } else {
      v->expected("an array of bytes or an object of node settings");
    }
  }
  return board;
}

VirtualRingTransport parse_virtual_ring(const Node& node, const ParseOptions& options) {
  const Object object(node);
  object.allow_only({"boards", "pacing", "seed"});
  VirtualRingTransport ring;
  const Node boards = object.required("boards");
  if (!boards.value.is_array() || boards.value.empty()) boards.expected("a non-empty array of boards");
  for_each_element(boards, [&](const Node& board, std::size_t i) {
    ring.boards.push_back(parse_ring_board(board, i, options));
  });
  if (auto v = object.optional("pacing")) ring.pacing = read_pacing(*v);
  if (auto v = object.optional("seed")) ring.seed = read_unsigned(*v);
  return ring;
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
                                const ParseOptions& options) {
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
  return parse_virtual_ring(inner, options);
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

void read_call_timing(const Object& object, session::CallTiming& timing) {
  if (auto v = object.optional("attempt_timeout_ms")) timing.attempt_timeout = read_ms(*v, 1);
  if (auto v = object.optional("call_budget_ms")) timing.call_budget = read_ms(*v, 1);
  if (auto v = object.optional("max_attempts")) timing.max_attempts = static_cast<std::uint8_t>(read_unsigned(*v, 1, 255));
}

RomiOptions parse_romi_options(const Object& object) {
  RomiOptions options;
  read_call_timing(object, options.timing);
  if (auto v = object.optional("retry_on_timeout")) options.timing.retry_on_timeout = read_bool(*v);
  if (auto v = object.optional("first_id")) options.first_id = static_cast<std::uint8_t>(read_unsigned(*v, 0, 254));
  return options;
}

const char* kind_name(PinInit::Kind kind) { return kind == PinInit::Kind::servo ? "servo" : "digital"; }

PinInit parse_init(const Node& node) {
  const Object object(node);
  PinInit init;
  const Node kind = object.required("kind");
  init.kind = read_choice(kind, "init kind", {"servo", "digital"}) == 0 ? PinInit::Kind::servo : PinInit::Kind::digital;
  if (init.kind == PinInit::Kind::servo) {
    object.allow_only({"kind", "pin", "safe_position"}, {{"safe_state", "is for digital inits (servo: safe_position)"}});
  } else {
    object.allow_only({"kind", "pin", "safe_state"}, {{"safe_position", "is for servo inits (digital: safe_state)"}});
  }
  init.pin = static_cast<std::uint32_t>(read_unsigned(object.required("pin"), 0, 255));
  if (init.kind == PinInit::Kind::servo) {
    init.safe_value = static_cast<std::int32_t>(read_unsigned(object.required("safe_position"), 0, 180));
  } else {
    init.safe_value = read_bool(object.required("safe_state")) ? 1 : 0;
  }
  return init;
}

ProxyDeviceOptions parse_proxy_options(const Object* object, Codec codec, const TransportConfig& transport) {
  ProxyDeviceOptions options;
  options.client = codec == Codec::proxy ? proxy::Options::primary() : proxy::Options::compat();
  if (const auto* serial = std::get_if<SerialTransport>(&transport)) options.client.timing.baud = serial->options.baud;
  if (object == nullptr) return options;
  proxy::ProxyTiming& timing = options.client.timing;
  if (auto v = object->optional("baud")) timing.baud = static_cast<std::uint32_t>(read_unsigned(*v, 1, 0xFFFFFFFFu));
  if (auto v = object->optional("bits_per_byte")) timing.bits_per_byte = static_cast<std::uint32_t>(read_unsigned(*v, 1, 64));
  if (auto v = object->optional("processing_margin_ms")) timing.processing_margin = read_ms(*v);
  if (auto v = object->optional("send_budget_ms")) timing.send_budget = read_ms(*v, 1);
  if (auto v = object->optional("max_sends")) timing.max_sends = static_cast<std::uint8_t>(read_unsigned(*v, 1, 255));
  if (auto v = object->optional("queue_timeout_ms")) timing.queue_timeout = read_ms(*v, 1);
  if (auto v = object->optional("ping_period_ms")) timing.ping_period = read_ms(*v);
  if (auto v = object->optional("reset_timeout_ms")) timing.session.reset_timeout = read_ms(*v, 1);
  if (auto v = object->optional("stale_after_ms")) timing.stale_after = read_ms(*v, 1);
  if (auto v = object->optional("replay_on_reset")) options.client.compat_replay_on_reset = read_bool(*v);
  if (auto v = object->optional("open_timeout_ms")) options.open_timeout = std::chrono::milliseconds(read_ms(*v, 1));
  if (auto v = object->optional("inits")) {
    if (!v->value.is_array()) v->expected("an array of inits");
    if (v->value.size() > proxy::kMaxInits) {
      fail(v->path, "expected at most " + std::to_string(proxy::kMaxInits) + " inits, got " +
                        std::to_string(v->value.size()));
    }
    for_each_element(*v, [&](const Node& element, std::size_t i) {
      const PinInit init = parse_init(element);
      for (std::size_t j = 0; j < i; ++j) {
        const PinInit& earlier = options.inits[j];
        if (earlier.kind == init.kind && earlier.pin == init.pin) {
          fail(element.path, std::string(kind_name(init.kind)) + " " + std::to_string(init.pin) +
                                 " is already initialised by inits[" + std::to_string(j) + "]");
        }
      }
      options.inits.push_back(init);
    });
  }
  return options;
}

ElcanoOptions parse_elcano_options(const Object* object, const TransportConfig& transport) {
  ElcanoOptions options;
  if (const auto* serial = std::get_if<SerialTransport>(&transport)) options.pacing.baud = serial->options.baud;
  if (object == nullptr) return options;
  if (auto v = object->optional("generation")) {
    options.generation = read_choice(*v, "generation", {"B", "D"}) == 0 ? elcano::Generation::b : elcano::Generation::d;
  }
  if (auto v = object->optional("capture")) options.capture = read_types(*v);
  if (auto v = object->optional("pacing")) {
    const Object pacing(*v);
    pacing.allow_only({"receiver_buffer", "receiver_poll_interval_ms"});
    if (auto p = pacing.optional("receiver_buffer")) {
      options.pacing.receiver_buffer = static_cast<std::uint16_t>(read_unsigned(*p, 1, 65535));
    }
    if (auto p = pacing.optional("receiver_poll_interval_ms")) {
      options.pacing.receiver_poll_interval = static_cast<std::uint16_t>(read_unsigned(*p, 0, 65535));
    }
  }
  read_call_timing(*object, options.timing);
  return options;
}

CodecOptions parse_options(const std::optional<Node>& node, const std::string& path, Codec codec,
                           const TransportConfig& transport) {
  const CodecRow& row = codec_row(codec);
  OptionsContext context;
  context.path = path;
  context.codec = codec;
  context.transport = &transport;
  if (node) {
    Object(*node).allow_only(row.option_keys, foreign_keys(row));
    context.options = &node->value;
  }
  return row.parse_options(context);
}

// The options object a built-in parser reads, if any.
std::optional<Object> options_object(const OptionsContext& context) {
  if (context.options == nullptr) return std::nullopt;
  return Object(Node{*context.options, context.path});
}

Names codec_names() {
  Names names;
  for (const CodecRow* row : codec_rows()) names.push_back(row->name);
  return names;
}

DeviceConfig parse_device(const Node& node, const ParseOptions& options) {
  const Object object(node);
  object.allow_only({"name", "codec", "transport", "options"});
  DeviceConfig device;
  device.name = read_nonempty_string(object.required("name"));
  const std::vector<const CodecRow*> rows = codec_rows();
  device.codec = rows.at(read_choice(object.required("codec"), "codec", codec_names()))->codec;
  device.transport = parse_transport(object.required("transport"), device.codec, device.name, options);
  device.options = parse_options(object.optional("options"), object.path() + ".options", device.codec, device.transport);
  return device;
}

// --- validation of typed configurations ----------------------------------------------------------------------

std::string device_path(std::size_t i) { return "devices[" + std::to_string(i) + "]"; }

void check_call_timing(const std::string& options_path, const session::CallTiming& timing) {
  if (timing.attempt_timeout == 0) fail(options_path + ".attempt_timeout_ms", "must be at least 1");
  if (timing.call_budget == 0) fail(options_path + ".call_budget_ms", "must be at least 1");
  if (timing.max_attempts == 0) fail(options_path + ".max_attempts", "must be at least 1");
}

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
  if (const auto* serial = std::get_if<SerialTransport>(&device.transport); serial && serial->path.empty()) {
    fail(transport_path + ".path", "must not be empty");
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

namespace detail {

CodecOptions parse_romi(const OptionsContext& context) {
  const std::optional<Object> object = options_object(context);
  return object ? parse_romi_options(*object) : RomiOptions();
}

CodecOptions parse_proxy(const OptionsContext& context) {
  const std::optional<Object> object = options_object(context);
  return parse_proxy_options(object ? &*object : nullptr, context.codec, *context.transport);
}

CodecOptions parse_elcano(const OptionsContext& context) {
  const std::optional<Object> object = options_object(context);
  return parse_elcano_options(object ? &*object : nullptr, *context.transport);
}

void validate_romi(const CodecOptions& codec_options, const std::string& options_path) {
  const auto* options = codec_options.get_if<RomiOptions>();
  if (options == nullptr) fail(options_path, "codec romi needs RomiOptions");
  check_call_timing(options_path, options->timing);
}

void validate_proxy(const CodecOptions& codec_options, const std::string& options_path, Codec codec) {
  const auto* options = codec_options.get_if<ProxyDeviceOptions>();
  if (options == nullptr) fail(options_path, "codec " + std::string(to_string(codec)) + " needs ProxyDeviceOptions");
  const proxy::Mode mode = codec == Codec::proxy ? proxy::Mode::primary : proxy::Mode::compat;
  if (options->client.mode != mode) {
    fail(options_path, "the client's mode does not match codec " + std::string(to_string(codec)));
  }
  const proxy::ProxyTiming& timing = options->client.timing;
  if (timing.baud == 0) fail(options_path + ".baud", "must be at least 1");
  if (timing.bits_per_byte == 0) fail(options_path + ".bits_per_byte", "must be at least 1");
  if (timing.send_budget == 0) fail(options_path + ".send_budget_ms", "must be at least 1");
  if (timing.max_sends == 0) fail(options_path + ".max_sends", "must be at least 1");
  if (options->inits.size() > proxy::kMaxInits) fail(options_path + ".inits", "too many inits");
  for (std::size_t k = 0; k < options->inits.size(); ++k) {
    const PinInit& init = options->inits[k];
    const std::string init_path = options_path + ".inits[" + std::to_string(k) + "]";
    if (init.kind == PinInit::Kind::servo && (init.safe_value < 0 || init.safe_value > 180)) {
      fail(init_path + ".safe_position", "must be in 0..180");
    }
    if (init.kind == PinInit::Kind::digital && init.safe_value != 0 && init.safe_value != 1) {
      fail(init_path + ".safe_state", "must be 0 or 1");
    }
    for (std::size_t j = 0; j < k; ++j) {
      if (options->inits[j].kind == init.kind && options->inits[j].pin == init.pin) {
        fail(init_path, std::string(kind_name(init.kind)) + " " + std::to_string(init.pin) +
                            " is already initialised by inits[" + std::to_string(j) + "]");
      }
    }
  }
}

void validate_elcano(const CodecOptions& codec_options, const std::string& options_path) {
  const auto* options = codec_options.get_if<ElcanoOptions>();
  if (options == nullptr) fail(options_path, "codec elcano needs ElcanoOptions");
  check_call_timing(options_path, options->timing);
  if (options->pacing.baud == 0) fail(options_path + ".pacing", "baud must be at least 1");
}

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
  if (!document.is_object()) fail("", "expected a JSON object at the top level, got " + show(document));
  const Object root(Node{document, ""});
  root.allow_only({"name", "devices"});
  RoverConfig config;
  if (auto v = root.optional("name")) config.name = read_string(*v);
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

}  // namespace

RoverConfig parse_config(std::string_view json_text, const ParseOptions& options) {
  return parse_document(parse_json_text(json_text), options);
}

NodeFile parse_node_file(std::string_view json_text) {
  const json document = parse_json_text(json_text);
  const Node root{document, ""};
  if (!document.is_object()) root.expected("an object of node settings");
  NodeFile file;
  file.settings = parse_node_settings(root, true, 0);
  const Object object(root);
  if (auto v = object.optional("generation")) {
    file.generation = read_choice(*v, "generation", {"B", "D"}) == 0 ? elcano::Generation::b : elcano::Generation::d;
  }
  // The node's own range: a baud it would refuse is an error at its key here, not a nameless one when the
  // block is encoded (found by fuzzing).
  if (auto v = object.optional("baud")) {
    file.baud = static_cast<std::uint32_t>(read_unsigned(*v, elcano::node::kMinBaud, elcano::node::kMaxBaud));
  }
  return file;
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
    return "serial " + serial->path + " " + std::to_string(serial->options.baud);
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
