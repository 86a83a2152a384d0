// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Interpolation tables with the semantics of the library's CombiTable blocks (MODELS.md §0.4).
//
//   Table1d: piecewise linear in x. A repeated x value is a zero-length segment (a step);
//            at such a point the table is right-continuous (takes the later row), so no
//            division by a zero interval can happen (NEDC has 31 repeated time stamps).
//            Outside the axis: linear from the last two points, hold the end value, or
//            repeat the table (periodic, as the library's EV examples drive their cycle).
//   Table2d: bilinear on a rectangular grid, u1 = row axis, u2 = column axis; outside
//            the grid, linear from the last two grid lines (P15..V2 behaviour, §1.4).
//
// Tables are built and validated at start-up; lookups allocate nothing and never search:
// they run inside every derivative evaluation.

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "plant/problems.hpp"

namespace ehpt::plant {

// Where u falls on a sorted axis, in O(1). An evenly spaced axis (maps, 1 Hz cycles) gives
// segment and fraction by one multiplication; any other axis gets a bucket grid built at
// start-up that maps u to the first candidate segment, and a short forward scan finishes
// (repeated values allowed: the scan moves past them).
class AxisIndex {
 public:
  struct Position {
    std::size_t i;  // segment [x[i], x[i+1]], kept within [0, n-2]
    double t;       // (u - x[i]) / (x[i+1] - x[i]); < 0 or > 1 outside the axis (extrapolation)
  };

  AxisIndex() = default;
  explicit AxisIndex(const std::vector<double>& x);

  // Run phase.
  // (Signed integers on purpose: double <-> int64 is one instruction, size_t is not.)
  [[gnu::always_inline]] Position locate(double u) const {
    const double k = (u - x0_) * inv_width_;
    if (uniform_) {
      std::int64_t i = k > 0.0 ? static_cast<std::int64_t>(k) : 0;  // NaN -> 0
      if (k >= buckets_) i = last_;
      return {static_cast<std::size_t>(i), k - static_cast<double>(i)};
    }
    std::int64_t i = 0;
    if (k >= buckets_) {
      i = last_;
    } else if (k > 0.0) {
      i = bucket_[static_cast<std::int64_t>(k)];
      while (i < last_ && x_[i + 1] <= u) ++i;
    }
    return {static_cast<std::size_t>(i), (u - x_[i]) * inv_dx_[i]};
  }

 private:
  std::vector<double> x_;
  std::vector<double> inv_dx_;         // 1 / (x[i+1] - x[i]); 0 for a zero-length segment
  double x0_ = 0.0, inv_width_ = 0.0;  // index = (u - x0) * inv_width
  double buckets_ = 0.0;               // uniform: n - 1 (k >= it means the last segment)
  std::int64_t last_ = 0;              // n - 2
  bool uniform_ = false;
  std::vector<std::uint32_t> bucket_;  // non-uniform: first segment that can hold a u of bucket k
};

enum class Extrapolation { kLinear, kHold, kPeriodic };

class Table1d {
 public:
  Table1d() = default;
  Table1d(std::vector<double> x, std::vector<double> y, Extrapolation extrapolation);

  // Run phase: no allocation.
  [[gnu::always_inline]] double operator()(double u) const {
    // inside the axis (the common case) no extrapolation rule is looked at
    if (u <= x_.front() || u >= x_.back()) return outside(u);
    return inside(u);
  }

  bool empty() const { return x_.empty(); }
  const std::vector<double>& x() const { return x_; }
  const std::vector<double>& y() const { return y_; }

 private:
  [[gnu::always_inline]] double inside(double u) const {
    const AxisIndex::Position p = index_.locate(u);
    return y_[p.i] + p.t * (y_[p.i + 1] - y_[p.i]);
  }
  // At or beyond an end of the axis (or NaN): hold, extrapolate linearly, or wrap.
  [[gnu::noinline]] double outside(double u) const {
    switch (extrapolation_) {
      case Extrapolation::kHold:
        return u <= x_.front() ? y_.front() : y_.back();
      case Extrapolation::kPeriodic:
        return inside(x_.front() + wrapped(u - x_.front()));
      case Extrapolation::kLinear:
        break;
    }
    return inside(u);  // locate() keeps the end segment, its fraction runs past [0, 1]
  }

  // The offset into the period, the bits of fmod (an exact operation): a - n span for the
  // n that puts it in [0, span). Where every n span up to max_periods_ is an exact double (a
  // span with few significant bits: 1180 s, 150 s), the remainder a - n span is exact too, so
  // one multiplication and a check replace the fmod call (~90 instructions); otherwise, and
  // for a < 0 or a NaN, fmod itself.
  [[gnu::always_inline]] double wrapped(double a) const {
    if (a >= 0.0 && a < max_wrap_) {
      auto n = static_cast<std::int64_t>(a * inv_span_);
      double r = a - static_cast<double>(n) * span_;
      if (r < 0.0) {
        r = a - static_cast<double>(--n) * span_;
      } else if (r >= span_) {
        r = a - static_cast<double>(++n) * span_;
      }
      if (r >= 0.0 && r < span_) return r;
    }
    double k = std::fmod(a, span_);
    if (k < 0.0) k += span_;
    return k;
  }

  std::vector<double> x_, y_;
  Extrapolation extrapolation_ = Extrapolation::kLinear;
  AxisIndex index_;
  double span_ = 0.0, inv_span_ = 0.0;  // periodic: the period and its inverse
  double max_wrap_ = 0.0;               // periodic: below it, n span is exact for every n needed
};

// At least two rows, finite values, x non-decreasing (repeats allowed when
// allow_repeats, e.g. a cycle's time stamps) or strictly increasing.
void validate(const Table1d& t, const std::string& field, bool allow_repeats, Problems& problems);

class Table2d {
 public:
  Table2d() = default;
  // values are row-major: values[i * u2.size() + j] belongs to (u1[i], u2[j]).
  Table2d(std::vector<double> u1, std::vector<double> u2, std::vector<double> values);

  // Run phase: no allocation. Unclamped fractions give linear extrapolation from the last
  // two grid lines.
  [[gnu::always_inline]] double operator()(double a, double b) const {
    const AxisIndex::Position pa = index1_.locate(a);
    const AxisIndex::Position pb = index2_.locate(b);
    const double* r0 = v_.data() + pa.i * n2_ + pb.i;
    const double* r1 = r0 + n2_;
    const double lo = r0[0] + pb.t * (r0[1] - r0[0]);
    const double hi = r1[0] + pb.t * (r1[1] - r1[0]);
    return lo + pa.t * (hi - lo);
  }

  bool empty() const { return u1_.empty(); }
  const std::vector<double>& u1() const { return u1_; }
  const std::vector<double>& u2() const { return u2_; }
  const std::vector<double>& values() const { return v_; }

 private:
  std::vector<double> u1_, u2_, v_;
  std::size_t n2_ = 0;
  AxisIndex index1_, index2_;
};

// At least 2 x 2, strictly increasing axes, finite values, values.size() = n1 * n2.
void validate(const Table2d& t, const std::string& field, Problems& problems);

}  // namespace ehpt::plant
