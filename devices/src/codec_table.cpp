// The codec table (codecs.hpp): the built-in rows and the ones a program registers.
#include <algorithm>
#include <deque>
#include <mutex>
#include <string>
#include <stdexcept>
#include <utility>

#include "builtin_codecs.hpp"
#include "tether/devices/codecs.hpp"

namespace tether::devices {

namespace {

// Values of registered codecs start here, clear of the built-in ones (and of any added later).
constexpr unsigned kFirstRegisteredValue = 16;

std::vector<CodecRow> builtin_rows() {
  std::vector<CodecRow> rows = detail::plugin_rows();
  // In the order of their values: the order configurations' error messages list them in.
  std::stable_sort(rows.begin(), rows.end(), [](const CodecRow& a, const CodecRow& b) {
    return static_cast<unsigned>(a.codec) < static_cast<unsigned>(b.codec);
  });
  // Each plugin declares its value: two plugins with one value, or one in the registered range, is a build
  // that cannot tell its codecs apart.
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const bool taken = i > 0 && rows[i].codec == rows[i - 1].codec;
    if (taken || static_cast<unsigned>(rows[i].codec) >= kFirstRegisteredValue) {
      throw std::logic_error("codec plugin " + std::string(rows[i].name) + ": its value " +
                             std::to_string(static_cast<unsigned>(rows[i].codec)) +
                             (taken ? " is " + std::string(rows[i - 1].name) + "'s" : " is not below 16"));
    }
  }
  return rows;
}

// Rows live in a deque: references stay valid while rows are added.
struct Table {
  std::mutex mutex;
  std::deque<CodecRow> rows;
  Table() {
    for (CodecRow& row : builtin_rows()) rows.push_back(std::move(row));
  }
};

Table& table() {
  static Table instance;
  return instance;
}

}  // namespace

const CodecRow& codec_row(Codec codec) {
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  for (const CodecRow& row : rows.rows) {
    if (row.codec == codec) return row;
  }
  throw std::out_of_range("no codec has the value " + std::to_string(static_cast<unsigned>(codec)));
}

const CodecRow* find_codec(std::string_view name) {
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  for (const CodecRow& row : rows.rows) {
    if (row.name == name) return &row;
  }
  return nullptr;
}

std::vector<const CodecRow*> codec_rows() {
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  std::vector<const CodecRow*> all;
  for (const CodecRow& row : rows.rows) all.push_back(&row);
  return all;
}

Codec register_codec(CodecRow row) {
  if (row.name.empty()) throw std::invalid_argument("register_codec: the row has no name");
  if (!row.parse_options || !row.open) {
    throw std::invalid_argument("register_codec: codec " + std::string(row.name) + " needs parse_options and open");
  }
  Table& rows = table();
  const std::lock_guard lock(rows.mutex);
  for (const CodecRow& existing : rows.rows) {
    if (existing.name == row.name) {
      throw std::invalid_argument("register_codec: codec " + std::string(row.name) + " exists already");
    }
  }
  const auto registered = static_cast<std::size_t>(std::count_if(rows.rows.begin(), rows.rows.end(), [](const CodecRow& each) {
    return static_cast<unsigned>(each.codec) >= kFirstRegisteredValue;
  }));
  if (kFirstRegisteredValue + registered > 0xFF) throw std::invalid_argument("register_codec: the table is full");
  row.codec = static_cast<Codec>(kFirstRegisteredValue + registered);
  rows.rows.push_back(std::move(row));
  return rows.rows.back().codec;
}

std::string_view to_string(Codec codec) {
  try {
    return codec_row(codec).name;
  } catch (const std::out_of_range&) {
    return "unknown";
  }
}

}  // namespace tether::devices
