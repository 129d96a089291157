// Answers read into typed values with nlohmann's SAX parser (the JSON grammar, escapes and numbers stay
// nlohmann's); a JSON document is built only for nested arrays/objects and on conversion.
#include "tether/romi/response.hpp"

#include <charconv>
#include <limits>
#include <ostream>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "tether/romi/errors.hpp"

namespace tether::romi {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------------------
// Value

Value Value::from_json(const json& value) {
  switch (value.type()) {
    case json::value_t::boolean:
      return Value(value.get<bool>());
    case json::value_t::number_integer:
      return Value(value.get<std::int64_t>());
    case json::value_t::number_unsigned: {
      const auto number = value.get<std::uint64_t>();
      if (number <= static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        return Value(static_cast<std::int64_t>(number));
      }
      return Value(number);
    }
    case json::value_t::number_float:
      return Value(value.get<double>());
    case json::value_t::string:
      return Value(value.get<std::string>());
    case json::value_t::array:
    case json::value_t::object:
    case json::value_t::binary:
      return Value(json(value));
    case json::value_t::null:
    case json::value_t::discarded:
      break;
  }
  return Value();
}

double Value::number() const {
  switch (kind()) {
    case Kind::integer:
      return static_cast<double>(integer());
    case Kind::unsigned_integer:
      return static_cast<double>(unsigned_integer());
    default:
      return std::get<double>(data_);
  }
}

json Value::to_json() const {
  return std::visit([](const auto& value) { return json(value); }, data_);
}

std::ostream& operator<<(std::ostream& out, const Value& value) { return out << value.to_json().dump(); }

// ---------------------------------------------------------------------------------------------------------
// Values

Values::Values(const json& document) {
  if (!document.is_array()) {
    values_.push_back(Value::from_json(document));
    array_ = false;
    return;
  }
  values_.reserve(document.size());
  for (const json& value : document) values_.push_back(Value::from_json(value));
}

const Value& Values::at(std::size_t index) const {
  if (index >= values_.size()) throw std::out_of_range("romi::Values::at: index past the last value");
  return values_[index];
}

json Values::to_json() const {
  if (!array_) return values_.empty() ? json() : values_.front().to_json();
  json array = json::array();
  array.get_ref<json::array_t&>().reserve(values_.size());
  for (const Value& value : values_) array.push_back(value.to_json());
  return array;
}

std::string Values::dump() const { return to_json().dump(); }

std::ostream& operator<<(std::ostream& out, const Values& values) { return out << values.dump(); }

void to_json(json& document, const Values& values) { document = values.to_json(); }

void to_json(nlohmann::ordered_json& document, const Values& values) {
  // Nested documents are nlohmann::json; their text is the one representation both types share.
  document = nlohmann::ordered_json::parse(values.dump());
}

// ---------------------------------------------------------------------------------------------------------
// The SAX reader

// nlohmann's SAX interface (json_sax): the top-level array's scalars become `Value`s as they are read;
// a nested array/object is built as a document (as nlohmann's DOM parser would) and becomes one `Value`.
// Anything but an array at the top is only validated (the caller tells -26 from -27).
class AnswerReader {
 public:
  explicit AnswerReader(Values& values) : values_(values) {}

  // Whether the document was an array (meaningful after a successful parse).
  bool was_array() const { return top_is_array_; }

  bool null() { return scalar(nullptr); }
  bool boolean(bool value) { return scalar(value); }
  bool number_integer(json::number_integer_t value) { return scalar(static_cast<std::int64_t>(value)); }
  bool number_unsigned(json::number_unsigned_t value) {
    if (value <= static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
      return scalar(static_cast<std::int64_t>(value));
    }
    return scalar(static_cast<std::uint64_t>(value));
  }
  bool number_float(json::number_float_t value, const json::string_t& /*text*/) {
    return scalar(static_cast<double>(value));
  }
  bool string(json::string_t& value) { return scalar(std::move(value)); }
  bool binary(json::binary_t& value) { return scalar(json::binary_t(std::move(value))); }

  bool start_array(std::size_t /*elements*/) { return open(json::array()); }
  bool start_object(std::size_t /*elements*/) { return open(json::object()); }
  bool key(json::string_t& key) {
    key_ = std::move(key);
    return true;
  }
  bool end_array() { return close(); }
  bool end_object() { return close(); }

  bool parse_error(std::size_t /*position*/, const std::string& /*token*/, const nlohmann::detail::exception&) {
    return false;
  }

 private:
  // A value outside any container (top level), in the top array, or nested deeper.
  template <typename T>
  bool scalar(T&& value) {
    if (depth_ == 0 || !top_is_array_) return true;  // a top-level scalar, or inside a top-level object
    if (nested_.empty()) {
      if constexpr (std::is_same_v<std::decay_t<T>, json::binary_t>) {
        values_.push_back(Value(json::binary(std::forward<T>(value))));
      } else if constexpr (std::is_same_v<std::decay_t<T>, std::nullptr_t>) {
        values_.push_back(Value());
      } else if constexpr (std::is_same_v<std::decay_t<T>, std::string>) {
        values_.push_back(Value(std::forward<T>(value)));
      } else {
        values_.push_back(Value(value));
      }
      return true;
    }
    if constexpr (std::is_same_v<std::decay_t<T>, json::binary_t>) {
      add(json::binary(std::forward<T>(value)));
    } else {
      add(json(std::forward<T>(value)));
    }
    return true;
  }

  bool open(json container) {
    ++depth_;
    if (depth_ == 1) {
      top_is_array_ = container.is_array();
      return true;
    }
    if (!top_is_array_) return true;
    if (nested_.empty()) {
      root_ = std::move(container);
      nested_.push_back(&root_);
    } else {
      nested_.push_back(add(std::move(container)));
    }
    return true;
  }

  bool close() {
    --depth_;
    if (!nested_.empty()) {
      nested_.pop_back();
      if (nested_.empty()) values_.push_back(Value(std::move(root_)));
    }
    return true;
  }

  // Adds `value` to the innermost open nested container; returns where it landed.
  json* add(json value) {
    json& container = *nested_.back();
    if (container.is_array()) {
      container.push_back(std::move(value));
      return &container.back();
    }
    json& slot = container[key_];
    slot = std::move(value);
    return &slot;
  }

  Values& values_;
  std::size_t depth_ = 0;
  bool top_is_array_ = false;
  json root_;                  // the nested array/object being built
  std::vector<json*> nested_;  // its open containers, innermost last
  std::string key_;            // the key of the next value in an open object
};

// ---------------------------------------------------------------------------------------------------------
// The common shape, read directly

// What Romi devices send nearly always: a flat array of integers and plain strings, no whitespace
// (`[0,1,2]`, `[101,"I will try again tomorrow"]`). Read without a lexer: integers with from_chars,
// strings of printable ASCII without escapes copied as they are. Returns false, leaving `values` to be
// cleared, at the first thing outside that shape (valid JSON or not): nlohmann's SAX parser then reads
// the whole body, so anything accepted here is JSON that nlohmann reads to the same values.
bool read_plain_array(std::string_view body, Values& values) {
  const char* at = body.data();
  const char* const end = at + body.size();
  if (end - at < 2 || *at != '[' || end[-1] != ']') return false;
  ++at;
  if (*at == ']') return false;  // empty: the SAX path and the caller's checks decide
  for (;;) {
    if (*at == '"') {
      const char* const text = ++at;
      while (at < end && *at != '"') {
        const auto c = static_cast<unsigned char>(*at);
        if (c < 0x20 || c > 0x7e || c == '\\') return false;  // escapes, control, UTF-8: SAX
        ++at;
      }
      if (at == end) return false;
      values.push_back(Value(std::string(text, static_cast<std::size_t>(at - text))));
      ++at;
    } else {
      const char* const digits = *at == '-' ? at + 1 : at;
      if (digits == end || *digits < '0' || *digits > '9') return false;
      if (*digits == '0' && digits + 1 < end && digits[1] >= '0' && digits[1] <= '9') return false;  // 01
      std::int64_t number = 0;
      const std::from_chars_result read = std::from_chars(at, end, number);
      if (read.ec != std::errc()) return false;  // beyond int64: SAX reads it unsigned or as a float
      at = read.ptr;
      if (*at == '.' || *at == 'e' || *at == 'E') return false;  // a float
      values.push_back(Value(number));
    }
    if (*at == ',' && at + 1 < end - 1) {
      ++at;
      continue;
    }
    return at == end - 1;  // the closing bracket, and nothing after it
  }
}

// ---------------------------------------------------------------------------------------------------------
// Answers

void describe_failure(RomiResponse& response, std::int16_t code, std::string message) {
  response.code = code;
  response.message = std::move(message);
  response.values = Values();
  response.values.push_back(Value(static_cast<std::int64_t>(code)));
  response.values.push_back(Value(response.message));
}

RomiResponse parse_answer(ByteView payload, char opcode) {
  RomiResponse response;
  response.answered = true;
  response.opcode = opcode;
  response.raw.assign(reinterpret_cast<const char*>(payload.data()), payload.size());
  const std::string_view body = payload.size() > 1 ? std::string_view(response.raw).substr(1) : std::string_view();
  if (body.empty()) {
    const auto code = static_cast<std::int16_t>(Error::client_empty_response);
    describe_failure(response, code, romi::describe(code));
    return response;
  }
  bool array = read_plain_array(body, response.values);
  if (!array) {
    response.values = Values();
    AnswerReader reader(response.values);
    if (!json::sax_parse(body.data(), body.data() + body.size(), &reader)) {  // defect B5: the reference throws
      const auto code = static_cast<std::int16_t>(Error::client_invalid_json);
      describe_failure(response, code, romi::describe(code));
      return response;
    }
    array = reader.was_array();
  }
  const Values& values = response.values;
  const bool has_code = array && !values.empty() && values[0].kind() == Value::Kind::integer &&
                        values[0].integer() >= std::numeric_limits<std::int16_t>::min() &&
                        values[0].integer() <= std::numeric_limits<std::int16_t>::max();
  if (!has_code) {
    const auto code = static_cast<std::int16_t>(Error::client_bad_response);
    describe_failure(response, code, romi::describe(code));
    return response;
  }
  response.code = static_cast<std::int16_t>(values[0].integer());
  if (response.code != 0) {
    response.message = values.size() > 1 && values[1].is_string() ? values[1].string()
                                                                   : std::string(romi::describe(response.code));
  }
  return response;
}

bool RomiResponse::unreadable_answer() const {
  const auto error = static_cast<Error>(code);
  return answered &&
         (error == Error::client_empty_response || error == Error::client_invalid_json || error == Error::client_bad_response);
}

}  // namespace tether::romi
