/// @file response.hpp
/// What a Romi call returns (`RomiResponse`) and how an answer's JSON array becomes one: read straight
/// into typed values (`Value`, `Values`), no JSON document on the way. The common shape (a flat array of
/// integers and escape-free ASCII strings: `[0,1,2]`, `[101,"I will try again tomorrow"]`) is read
/// directly; anything else goes through nlohmann's SAX parser, so the JSON grammar stays nlohmann's. A
/// `nlohmann::json` is a conversion (`Values::to_json`, `nlohmann::json j = response.values`), made only by
/// code that asks for one: building the document cost more than the rest of a response's handling.
///
/// `RomiResponse::values` was a `nlohmann::json`; `Values` keeps what code used of it: `==` with a JSON
/// document, `dump()`, `size()`, `[i]`/`at(i)` (a `Value` with `is_string()`, `get<T>()`, `==` with JSON),
/// assignment from a document, and implicit conversion to `nlohmann::json`/`ordered_json`.
#pragma once

#include <boost/container/small_vector.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <variant>

#include "tether/core/bytes.hpp"

namespace tether::romi {

/// One value of an answer array: what a Romi device sends (integers, strings, a float, true/false/null),
/// or any nested array/object, kept as a `nlohmann::json`.
class Value {
 public:
  /// The JSON type of the value.
  enum class Kind : std::uint8_t { null, boolean, integer, unsigned_integer, number, string, structured };

  /// JSON null.
  Value() = default;
  /// true / false.
  explicit Value(bool value) : data_(value) {}
  /// An integer in int64 range (the Romi codes and values).
  explicit Value(std::int64_t value) : data_(value) {}
  /// An integer above int64's range (JSON allows it; nlohmann reads it as unsigned).
  explicit Value(std::uint64_t value) : data_(value) {}
  /// A number with a fraction or exponent.
  explicit Value(double value) : data_(value) {}
  /// A string (JSON escapes already decoded).
  explicit Value(std::string value) : data_(std::move(value)) {}
  /// Any JSON value; arrays and objects stay `structured`, scalars become their kind.
  static Value from_json(const nlohmann::json& json);

  /// The JSON type.
  Kind kind() const { return static_cast<Kind>(data_.index()); }
  /// True for null.
  bool is_null() const { return kind() == Kind::null; }
  /// True for true/false.
  bool is_boolean() const { return kind() == Kind::boolean; }
  /// True for an integer (signed or above int64), like `nlohmann::json::is_number_integer`.
  bool is_number_integer() const { return kind() == Kind::integer || kind() == Kind::unsigned_integer; }
  /// True for any number.
  bool is_number() const { return is_number_integer() || kind() == Kind::number; }
  /// True for a string.
  bool is_string() const { return kind() == Kind::string; }
  /// True for a nested array or object.
  bool is_structured() const { return kind() == Kind::structured; }

  /// The boolean; `is_boolean()` is the caller's duty.
  bool boolean() const { return std::get<bool>(data_); }
  /// The integer; `kind() == Kind::integer` is the caller's duty.
  std::int64_t integer() const { return std::get<std::int64_t>(data_); }
  /// The integer above int64's range; `kind() == Kind::unsigned_integer` is the caller's duty.
  std::uint64_t unsigned_integer() const { return std::get<std::uint64_t>(data_); }
  /// Any number as a double; `is_number()` is the caller's duty.
  double number() const;
  /// The string; `is_string()` is the caller's duty.
  const std::string& string() const { return std::get<std::string>(data_); }
  /// The nested array or object; `is_structured()` is the caller's duty.
  const nlohmann::json& structured() const { return std::get<nlohmann::json>(data_); }

  /// The value as a JSON document (a conversion: it builds one).
  nlohmann::json to_json() const;
  /// `to_json().get<T>()`, for code written when values were `nlohmann::json`.
  template <typename T>
  T get() const {
    return to_json().template get<T>();
  }

  /// Same JSON value (numbers compare like nlohmann's: 1 == 1u == 1.0).
  friend bool operator==(const Value& value, const nlohmann::json& json) { return value.to_json() == json; }
  /// Same kind and content.
  friend bool operator==(const Value& a, const Value& b) { return a.data_ == b.data_; }
  /// The value as compact JSON (test failure messages, logs).
  friend std::ostream& operator<<(std::ostream& out, const Value& value);

 private:
  friend class AnswerReader;
  explicit Value(nlohmann::json structured) : data_(std::move(structured)) {}

  // Alternatives in the order of `Kind`.
  std::variant<std::nullptr_t, bool, std::int64_t, std::uint64_t, double, std::string, nlohmann::json> data_;
};

/// The values of an answer array, code included (`[0,1,2]` -> 0, 1, 2). Up to 12 values (a Romi request's
/// limit, and more than the usual answer) are held without a heap allocation.
class Values {
 public:
  /// Values kept inline; more go to the heap.
  static constexpr std::size_t kInline = 12;

  /// No values (an empty array).
  Values() = default;
  /// Converts a JSON document: an array's elements; any other value is kept whole (`is_array()` false),
  /// for code that stored arbitrary JSON when values were `nlohmann::json`.
  Values(const nlohmann::json& json);  // NOLINT(google-explicit-constructor): was a nlohmann::json

  /// Number of values.
  std::size_t size() const { return values_.size(); }
  /// True without values.
  bool empty() const { return values_.empty(); }
  /// Value `index`; `index < size()` is the caller's duty.
  const Value& operator[](std::size_t index) const { return values_[index]; }
  /// Value `index`; throws `std::out_of_range` past the end (like `nlohmann::json::at`).
  const Value& at(std::size_t index) const;
  /// First value.
  const Value* begin() const { return values_.data(); }
  /// Past the last value.
  const Value* end() const { return values_.data() + values_.size(); }
  /// Appends a value.
  void push_back(Value value) { values_.push_back(std::move(value)); }
  /// False only for a non-array document converted with `Values(json)`.
  bool is_array() const { return array_; }

  /// The values as a JSON array (a conversion: it builds the document).
  nlohmann::json to_json() const;
  /// `to_json().dump()`, written straight from the typed values.
  std::string dump() const;

  /// Same JSON document as `json`.
  friend bool operator==(const Values& values, const nlohmann::json& json) { return values.to_json() == json; }
  /// Same values.
  friend bool operator==(const Values& a, const Values& b) { return a.array_ == b.array_ && a.values_ == b.values_; }
  /// Compact JSON (test failure messages, logs).
  friend std::ostream& operator<<(std::ostream& out, const Values& values);

 private:
  boost::container::small_vector<Value, kInline> values_;
  bool array_ = true;
};

/// `nlohmann::json json = values;` and `{"values", response.values}` in a JSON initializer.
void to_json(nlohmann::json& json, const Values& values);
/// The same for `nlohmann::ordered_json` (the CLI's output keeps key order).
void to_json(nlohmann::ordered_json& json, const Values& values);

/// What a call produced. See client.hpp's overview for which outcomes carry an error_code.
struct RomiResponse {
  /// First value of the answer: 0 success, > 0 application error, < 0 protocol error (device or host).
  std::int16_t code = 0;
  /// The whole answer array, code included: `[0,1,2]`, `[101,"I will try again tomorrow"]`.
  /// Without an intact answer (and for -23/-26/-27): `[code, message]`.
  Values values;
  /// Empty for code 0. Otherwise the device's message (second value, when it is a string), else the
  /// text of the code (`romi::describe(code)`; for transport failures the transport error's message).
  std::string message;
  /// The opcode of the answer (the request's opcode when there was no answer).
  char opcode = '\0';
  /// The wire id of the call (0 for manual calls and for commands rejected before sending).
  std::uint8_t id = 0;
  /// Frames sent for this call (0 when rejected before sending; > 1 after re-sends).
  std::uint8_t attempts = 0;
  /// True when an intact answer of the device is in `values` (false exactly when the error_code is set).
  bool answered = false;
  /// The answer's payload as received (opcode + array text), empty without an answer.
  std::string raw;

  /// True for code 0.
  bool ok() const { return code == 0; }
  /// True for a positive (application) code.
  bool application_error() const { return code > 0; }
  /// True when the device answered but its array could not be read (-23 empty, -26 invalid JSON, -27 not
  /// an array starting with a code): `raw` holds what arrived, worth showing.
  bool unreadable_answer() const;
};

/// Reads an intact answer frame's `payload` (the opcode, then the JSON array) into a response with
/// `answered` set: `code` from the first value, `message` from the second when the code is not 0. An
/// answer without a readable code is described by a host code: -23 no array text, -26 not JSON, -27 not
/// an array starting with an int16.
RomiResponse parse_answer(ByteView payload, char opcode);

/// Fills `response` with a failure that has no answer: `code`, `message` and values `[code, message]`.
void describe_failure(RomiResponse& response, std::int16_t code, std::string message);

}  // namespace tether::romi
