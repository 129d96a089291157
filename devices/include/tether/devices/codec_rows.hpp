/// @file codec_rows.hpp
/// A table of one kind of per-codec rows, found by the codec's name: what each program part that keeps its
/// own columns of the codec table (the `tether` command's rows, the demo's workloads) holds them in. Rows
/// come from the codec plugins first, then from programs that register codecs at start-up.
#pragma once

#include <deque>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tether::devices {

/// Rows of type `Row` (which has a `std::string_view name`), at most one per codec name. Thread-safe;
/// rows are never removed, and a row's address stays valid while others are added.
template <typename Row>
class CodecRows {
 public:
  /// A table holding `rows` (the plugins', in their order).
  explicit CodecRows(std::vector<Row> rows) {
    for (Row& row : rows) rows_.push_back(std::move(row));
  }

  /// The row named `name`, or null.
  const Row* find(std::string_view name) const {
    const std::lock_guard lock(mutex_);
    for (const Row& row : rows_) {
      if (row.name == name) return &row;
    }
    return nullptr;
  }

  /// Adds `row`. Throws `std::invalid_argument` (its text after `what`: "codec NAME has one already")
  /// when a row of that name exists.
  void add(Row row, std::string_view what) {
    const std::lock_guard lock(mutex_);
    for (const Row& existing : rows_) {
      if (existing.name == row.name) {
        throw std::invalid_argument(std::string(what) + ": codec " + std::string(row.name) + " has one already");
      }
    }
    rows_.push_back(std::move(row));
  }

 private:
  mutable std::mutex mutex_;
  std::deque<Row> rows_;
};

}  // namespace tether::devices
