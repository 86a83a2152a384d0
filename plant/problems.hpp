// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Load-time validation results. Every validate() in plant/ appends to a Problems list
// instead of stopping at the first error, so a user sees every mistake in one run.
// The loader (hil/config) turns the dotted field into file:line.

#include <string>
#include <vector>

namespace ehpt::plant {

struct Problem {
  std::string field;     // dotted path as written in the vehicle file, e.g. "battery.r0_cell_Ohm"
  std::string value;     // the value found, as text
  std::string expected;  // what was expected, e.g. "must be > 0"
  // A cell of a table (field names the table): row in the table's order and which column,
  // 0 = axis (x, or a map's row axis), 1 = values of a curve or a map's column axis,
  // 2 = a map's values. The loader turns them into file line, CSV column and the value as
  // written (before any unit conversion). -1: the whole table or a plain field.
  int row = -1;
  int column = -1;
};

class Problems {
 public:
  void add(std::string field, std::string value, std::string expected) {
    list_.push_back({std::move(field), std::move(value), std::move(expected)});
  }
  void add_cell(std::string field, std::size_t row, int column, std::string value, std::string expected) {
    list_.push_back({std::move(field), std::move(value), std::move(expected), static_cast<int>(row), column});
  }
  // Checks written so that NaN fails too: require(!(x > 0.0)) would accept NaN.
  void require_positive(const std::string& field, double value);
  void require_non_negative(const std::string& field, double value);
  void require_finite(const std::string& field, double value);
  void require_in(const std::string& field, double value, double lo, double hi,
                  bool lo_open = false, bool hi_open = false);
  bool empty() const { return list_.empty(); }
  std::size_t size() const { return list_.size(); }
  const std::vector<Problem>& list() const { return list_; }

 private:
  std::vector<Problem> list_;
};

// Shortest text that reads back to the same double ("0.1", "-3", "nan").
std::string number_text(double value);

}  // namespace ehpt::plant
