/// @file json_reader.hpp
/// Reading a configuration's JSON the way the configuration parser does, for a codec's option parser
/// (codecs.hpp): every value is read with its JSON path, and whatever is wrong with it is a `ConfigError`
/// that names the path and says what was expected (docs/config.md, "Errors"):
///
/// @code
///   const devices::JsonObject object(devices::JsonNode{json, "devices[0].options"});
///   object.allow_only({"timeout_ms", "greeting"});       // an unknown key: "did you mean ...?"
///   if (const auto timeout = object.optional("timeout_ms")) options.timeout_ms = devices::read_ms(*timeout, 1);
///   // devices[0].options.timeout_ms: expected an unsigned integer in 1..2147483647, got string "fast"
/// @endcode
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tether/core/time.hpp"

namespace tether::devices {

/// Names a value may take (keys, choices), in the order messages list them.
using Names = std::vector<std::string_view>;

/// Throws `ConfigError(path, detail)` (code `DevicesError::invalid_config`).
[[noreturn]] void fail_config(const std::string& path, std::string detail);

/// `text` as a JSON string literal (quotes, escapes): how messages quote keys and names.
std::string quote_json(std::string_view text);
/// How a value is shown after "got": `string "fast"`, `number -3`, `boolean true`, `null`, `object`, `array`.
std::string show_json(const nlohmann::json& value);
/// True when `names` holds `name`.
bool contains_name(const Names& names, std::string_view name);
/// `names` joined by `separator`.
std::string join_names(const Names& names, std::string_view separator = ", ");
/// The closest of `candidates` when it is plausibly a typo of `word` (edit distance, transpositions counted
/// once); nothing when none is.
std::optional<std::string_view> closest_name(std::string_view word, const Names& candidates);

/// A JSON value and its path (`devices[1].options.baud`).
struct JsonNode {
  const nlohmann::json& value;  ///< The value (not owned).
  std::string path;             ///< Its JSON path; empty for the document.

  /// The member `name` (which must exist: see `JsonObject`).
  JsonNode key(std::string_view name) const;
  /// The element `i` (which must exist).
  JsonNode index(std::size_t i) const;
  /// The number of elements of an array (members of an object; 1 for any other value, as nlohmann's `size`).
  std::size_t size() const;
  /// Throws "PATH: expected WHAT, got SHOWN".
  [[noreturn]] void expected(std::string_view what) const;
};

/// An object node: its keys checked, its members reached. Throws "expected an object" when it is not one.
class JsonObject {
 public:
  /// Checks that `node` is an object.
  explicit JsonObject(const JsonNode& node);
  /// The node.
  const JsonNode& node() const { return node_; }
  /// Its path.
  const std::string& path() const { return node_.path; }
  /// Every key must be in `allowed`: another is an error that suggests a close match or lists the allowed
  /// ones; `elsewhere` (key -> "does not apply to ...") explains keys that belong to something else.
  void allow_only(const Names& allowed, const std::map<std::string, std::string>& elsewhere = {}) const;
  /// True when the object has `key`.
  bool has(std::string_view key) const;
  /// The member `key`, or nothing.
  std::optional<JsonNode> optional(std::string_view key) const;
  /// The member `key`; "missing key" when there is none.
  JsonNode required(std::string_view key) const;

 private:
  JsonNode node_;
};

/// An unsigned integer in `min`..`max` (a signed one >= 0 from a document built in code counts).
std::uint64_t read_unsigned(const JsonNode& node, std::uint64_t min = 0,
                            std::uint64_t max = std::numeric_limits<std::uint64_t>::max());
/// A duration in milliseconds, `min`..2^31 - 1 (the engine's deadlines stay comparable).
Duration read_ms(const JsonNode& node, Duration min = 0);
/// A boolean.
bool read_bool(const JsonNode& node);
/// A string.
std::string read_string(const JsonNode& node);
/// A string that is not empty.
std::string read_nonempty_string(const JsonNode& node);
/// A number in [0, 1].
double read_rate(const JsonNode& node);
/// One of `names`, returned as its index; `what` names the kind of value in messages ("codec").
std::size_t read_choice(const JsonNode& node, std::string_view what, const Names& names);

/// JSON text as a configuration is read (comments allowed; a key given twice in one object, nesting deeper
/// than `kMaxConfigDepth` or text over `kMaxConfigBytes` refused): for a file of a codec's own, such as a
/// board's EEPROM file. Throws `ConfigError` (`invalid JSON: parse error at line L, column C: ...`).
nlohmann::json parse_json_text(std::string_view json_text);

/// Calls `visit(element_node, i)` for each element of an array node.
template <typename Visit>
void for_each_element(const JsonNode& node, Visit visit) {
  for (std::size_t i = 0, count = node.size(); i < count; ++i) visit(node.index(i), i);
}

}  // namespace tether::devices
