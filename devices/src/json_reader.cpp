// Reading configuration JSON with paths and suggestions (json_reader.hpp).
#include "tether/devices/json_reader.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <utility>

#include "tether/devices/config.hpp"

namespace tether::devices {

namespace {

using json = nlohmann::json;

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

}  // namespace

bool contains_name(const Names& names, std::string_view name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

void fail_config(const std::string& path, std::string detail) { throw ConfigError(path, std::move(detail)); }

std::string quote_json(std::string_view text) { return json(std::string(text)).dump(); }

std::string show_json(const json& value) {
  switch (value.type()) {
    case json::value_t::string:
      return "string " + value.dump();
    case json::value_t::boolean:
      return std::string("boolean ") + (value.get<bool>() ? "true" : "false");
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "number " + value.dump();
    case json::value_t::null:
      return "null";
    case json::value_t::object:
      return value.empty() ? "an empty object" : "object";
    case json::value_t::array:
      return value.empty() ? "an empty array" : "array";
    default:
      return "an invalid value";
  }
}

std::string join_names(const Names& names, std::string_view separator) {
  std::string text;
  for (std::string_view name : names) {
    if (!text.empty()) text += separator;
    text += name;
  }
  return text;
}

std::optional<std::string_view> closest_name(std::string_view word, const Names& candidates) {
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

JsonNode JsonNode::key(std::string_view name) const {
  return JsonNode{value.at(std::string(name)), path.empty() ? std::string(name) : path + "." + std::string(name)};
}

JsonNode JsonNode::index(std::size_t i) const { return JsonNode{value.at(i), path + "[" + std::to_string(i) + "]"}; }

std::size_t JsonNode::size() const { return value.size(); }

void JsonNode::expected(std::string_view what) const {
  fail_config(path, "expected " + std::string(what) + ", got " + show_json(value));
}

JsonObject::JsonObject(const JsonNode& node) : node_(node) {
  if (!node.value.is_object()) node.expected("an object");
}

void JsonObject::allow_only(const Names& allowed, const std::map<std::string, std::string>& elsewhere) const {
  for (const auto& item : node_.value.items()) {
    const std::string& key = item.key();
    if (contains_name(allowed, key)) continue;
    if (const auto other = elsewhere.find(key); other != elsewhere.end()) {
      fail_config(path(), "key " + quote_json(key) + " " + other->second);
    }
    if (const auto near = closest_name(key, allowed)) {
      fail_config(path(), "unknown key " + quote_json(key) + " (did you mean " + quote_json(*near) + "?)");
    }
    fail_config(path(), "unknown key " + quote_json(key) + " (allowed: " + join_names(allowed) + ")");
  }
}

bool JsonObject::has(std::string_view key) const { return node_.value.contains(std::string(key)); }

std::optional<JsonNode> JsonObject::optional(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return node_.key(key);
}

JsonNode JsonObject::required(std::string_view key) const {
  if (!has(key)) fail_config(path(), "missing key " + quote_json(key));
  return node_.key(key);
}

std::uint64_t read_unsigned(const JsonNode& node, std::uint64_t min, std::uint64_t max) {
  const json& value = node.value;
  // Parsed text stores non-negative integers as unsigned; documents built in code may hold them signed.
  const bool unsigned_integer =
      value.is_number_unsigned() || (value.is_number_integer() && value.get<std::int64_t>() >= 0);
  if (!unsigned_integer) node.expected("an unsigned integer");
  const auto number = value.get<std::uint64_t>();
  if (number < min || number > max) {
    fail_config(node.path, "expected an unsigned integer in " + std::to_string(min) + ".." + std::to_string(max) +
                               ", got " + std::to_string(number));
  }
  return number;
}

Duration read_ms(const JsonNode& node, Duration min) {
  return static_cast<Duration>(read_unsigned(node, min, 0x7FFFFFFFu));
}

bool read_bool(const JsonNode& node) {
  if (!node.value.is_boolean()) node.expected("a boolean");
  return node.value.get<bool>();
}

std::string read_string(const JsonNode& node) {
  if (!node.value.is_string()) node.expected("a string");
  return node.value.get<std::string>();
}

std::string read_nonempty_string(const JsonNode& node) {
  if (!node.value.is_string() || node.value.get_ref<const std::string&>().empty()) node.expected("a non-empty string");
  return node.value.get<std::string>();
}

double read_rate(const JsonNode& node) {
  if (!node.value.is_number()) node.expected("a number in [0, 1]");
  const double rate = node.value.get<double>();
  if (!(rate >= 0.0 && rate <= 1.0)) node.expected("a number in [0, 1]");
  return rate;
}

std::size_t read_choice(const JsonNode& node, std::string_view what, const Names& names) {
  if (!node.value.is_string()) {
    node.expected("a " + std::string(what) + " name (one of " + join_names(names) + ")");
  }
  const auto& text = node.value.get_ref<const std::string&>();
  std::size_t i = 0;
  for (std::string_view name : names) {
    if (name == text) return i;
    ++i;
  }
  std::string detail =
      "unknown " + std::string(what) + " " + quote_json(text) + " (expected one of " + join_names(names) + ")";
  if (const auto near = closest_name(text, names)) detail += "; did you mean " + quote_json(*near) + "?";
  fail_config(node.path, detail);
}

}  // namespace tether::devices
