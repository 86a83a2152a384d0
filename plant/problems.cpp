// SPDX-License-Identifier: BSD-3-Clause
#include "plant/problems.hpp"

#include <charconv>
#include <cmath>

namespace ehpt::plant {

std::string number_text(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, r.ptr);
}

void Problems::require_positive(const std::string& field, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) add(field, number_text(value), "must be a finite number > 0");
}

void Problems::require_non_negative(const std::string& field, double value) {
  if (!(value >= 0.0) || !std::isfinite(value)) add(field, number_text(value), "must be a finite number >= 0");
}

void Problems::require_finite(const std::string& field, double value) {
  if (!std::isfinite(value)) add(field, number_text(value), "must be a finite number");
}

void Problems::require_in(const std::string& field, double value, double lo, double hi,
                          bool lo_open, bool hi_open) {
  const bool lo_ok = lo_open ? value > lo : value >= lo;
  const bool hi_ok = hi_open ? value < hi : value <= hi;
  if (!(lo_ok && hi_ok)) {
    add(field, number_text(value),
        std::string("must be in ") + (lo_open ? "(" : "[") + number_text(lo) + ", " +
            number_text(hi) + (hi_open ? ")" : "]"));
  }
}

}  // namespace ehpt::plant
