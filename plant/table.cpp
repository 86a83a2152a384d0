// SPDX-License-Identifier: BSD-3-Clause
#include "plant/table.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {
AxisIndex::AxisIndex(const std::vector<double>& x) : x_(x) {
  // only for axes that passed validate(): at least 2 points, sorted, non-zero span
  if (x.size() < 2 || !(x.back() > x.front())) return;
  const std::size_t n = x.size();
  last_ = static_cast<std::int64_t>(n) - 2;
  x0_ = x.front();
  for (std::size_t i = 0; i + 1 < n; ++i) inv_dx_.push_back(x[i + 1] > x[i] ? 1.0 / (x[i + 1] - x[i]) : 0.0);
  const double span = x.back() - x.front();
  uniform_ = true;
  for (std::size_t i = 0; i < n; ++i) {
    const double expected = x0_ + span * static_cast<double>(i) / static_cast<double>(n - 1);
    uniform_ = uniform_ && std::abs(x[i] - expected) <= 1e-12 * span;
  }
  if (uniform_) {
    buckets_ = static_cast<double>(n - 1);
    inv_width_ = buckets_ / span;
    return;
  }
  const std::size_t buckets = std::min<std::size_t>(16 * n, 1u << 18);
  buckets_ = static_cast<double>(buckets);
  inv_width_ = buckets_ / span;
  bucket_.resize(buckets);
  std::size_t i = 0;
  for (std::size_t k = 0; k < buckets; ++k) {
    // the last segment starting at or before the bucket's lower edge, with half a bucket of
    // margin so that rounding in locate() can never skip past the right segment
    const double lower = x0_ + (static_cast<double>(k) - 0.5) / inv_width_;
    while (i + 2 < n && x[i + 1] <= lower) ++i;
    bucket_[k] = static_cast<std::uint32_t>(i);
  }
}

Table1d::Table1d(std::vector<double> x, std::vector<double> y, Extrapolation extrapolation)
    : x_(std::move(x)), y_(std::move(y)), extrapolation_(extrapolation), index_(x_) {
  if (extrapolation_ != Extrapolation::kPeriodic || x_.size() < 2) return;
  span_ = x_.back() - x_.front();
  if (!(span_ > 0.0) || !std::isfinite(span_)) return;  // validate() names it; fmod then
  inv_span_ = 1.0 / span_;
  // span = M 2^e with M odd: n span is exact while n M < 2^53. Periods up to 2^(53 - bits(M))
  // - 2 (one spare for the estimate of n being one high) take the fast path.
  int e = 0;
  auto m = static_cast<std::uint64_t>(std::ldexp(std::frexp(span_, &e), 53));  // 53-bit significand
  int bits = 53;
  while ((m & 1u) == 0) {
    m >>= 1;
    --bits;
  }
  const int spare = std::min(53 - bits, 40);
  if (spare >= 2) max_wrap_ = static_cast<double>((std::int64_t{1} << spare) - 2) * span_;
}

void validate(const Table1d& t, const std::string& field, bool allow_repeats, Problems& problems) {
  const auto& x = t.x();
  const auto& y = t.y();
  if (x.size() < 2 || x.size() != y.size()) {
    problems.add(field, std::to_string(x.size()) + " rows", "needs at least 2 rows");
    return;
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
      const int column = std::isfinite(x[i]) ? 1 : 0;
      problems.add_cell(field, i, column, number_text(column == 0 ? x[i] : y[i]), "must be a finite number");
      return;
    }
    if (i > 0) {
      const bool ok = allow_repeats ? x[i] >= x[i - 1] : x[i] > x[i - 1];
      if (!ok) {
        problems.add_cell(field, i, 0, number_text(x[i]),
                     std::string("axis must be ") + (allow_repeats ? "non-decreasing" : "strictly increasing") +
                         " (previous value " + number_text(x[i - 1]) + ")");
        return;
      }
    }
  }
  if (!(x.back() > x.front())) problems.add(field, number_text(x.back()), "axis must span a non-zero range");
}

Table2d::Table2d(std::vector<double> u1, std::vector<double> u2, std::vector<double> values)
    : u1_(std::move(u1)), u2_(std::move(u2)), v_(std::move(values)), n2_(u2_.size()), index1_(u1_), index2_(u2_) {}

void validate(const Table2d& t, const std::string& field, Problems& problems) {
  // a row-axis value first appears in table row i * n2, a column-axis value in row j
  const std::size_t n2 = t.u2().size();
  const auto check_axis = [&](const std::vector<double>& ax, int column, std::size_t row_stride, const char* name) {
    if (ax.size() < 2) {
      problems.add(field, std::to_string(ax.size()) + (ax.size() == 1 ? " value" : " values") + " on the " + name,
                   "a map needs at least 2 values on each axis");
      return false;
    }
    for (std::size_t i = 0; i < ax.size(); ++i) {
      if (!std::isfinite(ax[i]) || (i > 0 && !(ax[i] > ax[i - 1]))) {
        problems.add_cell(field, i * row_stride, column, number_text(ax[i]),
                          std::string(name) + " must be finite and strictly increasing");
        return false;
      }
    }
    return true;
  };
  const bool ok1 = check_axis(t.u1(), 0, n2, "row axis");
  const bool ok2 = check_axis(t.u2(), 1, 1, "column axis");
  if (!ok1 || !ok2) return;
  if (t.values().size() != t.u1().size() * t.u2().size()) {
    problems.add(field, std::to_string(t.values().size()) + " values",
                 "grid needs " + std::to_string(t.u1().size() * t.u2().size()) + " values (every row x column)");
    return;
  }
  for (std::size_t k = 0; k < t.values().size(); ++k) {
    if (!std::isfinite(t.values()[k])) {
      problems.add_cell(field, k, 2, number_text(t.values()[k]), "must be a finite number");
      return;
    }
  }
}

}  // namespace ehpt::plant
