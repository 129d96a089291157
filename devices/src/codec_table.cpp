// The codec table (codecs.hpp): the built-in rows and the ones a program registers.
#include <algorithm>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "builtin_codecs.hpp"
#include "tether/devices/codecs.hpp"

namespace tether::devices {

namespace {

// Values of registered codecs start here, clear of the built-in ones (and of any added later).
constexpr unsigned kFirstRegisteredValue = 16;

std::vector<CodecRow> builtin_rows() {
  std::vector<CodecRow> rows(4);
  rows[0].codec = Codec::romi;
  rows[0].name = "romi";
  rows[0].client_name = "romi::Client";
  rows[0].option_keys = {"attempt_timeout_ms", "call_budget_ms", "max_attempts", "retry_on_timeout", "first_id"};
  rows[0].parse_options = detail::parse_romi;
  rows[0].validate = detail::validate_romi;
  rows[0].open = detail::open_romi;

  // proxy and proxy-compat: one client and parser, the mode from the codec.
  const auto proxy_row = [](CodecRow& row, Codec codec, std::string_view name, std::string_view client_name) {
    row.codec = codec;
    row.name = name;
    row.client_name = client_name;
    row.parse_options = detail::parse_proxy;
    row.validate = [codec](const CodecOptions& options, const std::string& path) {
      detail::validate_proxy(options, path, codec);
    };
    row.open = detail::open_proxy;
    row.await_ready = detail::await_proxy;
  };
  proxy_row(rows[1], Codec::proxy, "proxy", "proxy::Client");
  rows[1].option_keys = {"baud",           "bits_per_byte",    "processing_margin_ms", "send_budget_ms",
                         "max_sends",      "queue_timeout_ms", "ping_period_ms",       "reset_timeout_ms",
                         "open_timeout_ms", "inits"};
  proxy_row(rows[2], Codec::proxy_compat, "proxy-compat", "proxy::Client (proxy::Options::compat())");
  rows[2].option_keys = {"queue_timeout_ms", "stale_after_ms", "replay_on_reset", "open_timeout_ms", "inits"};
  rows[2].default_baud = 57600;  // the deployed firmware's

  rows[3].codec = Codec::elcano;
  rows[3].name = "elcano";
  rows[3].client_name = "elcano::RingClient";
  rows[3].option_keys = {"generation", "capture", "pacing", "attempt_timeout_ms", "call_budget_ms", "max_attempts"};
  rows[3].virtual_boards = VirtualBoards::ring;
  rows[3].parse_options = detail::parse_elcano;
  rows[3].validate = detail::validate_elcano;
  rows[3].open = detail::open_elcano;
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

}  // namespace tether::devices
