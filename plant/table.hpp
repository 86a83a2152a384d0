#pragma once
// Interpolation tables with the semantics of the library's CombiTable blocks (MODELS.md §0.4).
//
//   Table1d: piecewise linear in x. A repeated x value is a zero-length segment (a step);
//            at such a point the table is right-continuous (takes the later row), so no
//            division by a zero interval can happen (NEDC has 31 repeated time stamps).
//            Outside the axis: linear from the last two points, or hold the end value.
//   Table2d: bilinear on a rectangular grid, u1 = row axis, u2 = column axis; outside
//            the grid, linear from the last two grid lines (P15..V2 behaviour, §1.4).
//
// Tables are built and validated at start-up; lookups allocate nothing.

#include <cstdint>
#include <string>
#include <vector>

#include "plant/problems.hpp"

namespace ehpt::plant {

// Finds the segment of a sorted axis in O(1), without a binary search in the step loop.
// An evenly spaced axis (maps, 1 Hz cycles) gives the index by one multiplication; any
// other axis gets a bucket grid built at start-up that maps u to the first candidate
// segment, and a short forward scan finishes (repeated values allowed).
class AxisIndex {
 public:
  AxisIndex() = default;
  explicit AxisIndex(const std::vector<double>& x);
  // Run phase: the last i with x[i] <= u, kept within [0, n-2].
  std::size_t segment(const double* x, double u) const {
    const double k = (u - x0_) * inv_width_;
    if (!(k > 0.0)) return 0;  // below the axis (or NaN)
    if (k >= buckets_) return last_;
    std::size_t i = static_cast<std::size_t>(k);
    if (uniform_) return i < last_ ? i : last_;
    i = bucket_[i];
    while (i < last_ && x[i + 1] <= u) ++i;
    return i;
  }

 private:
  double x0_ = 0.0, inv_width_ = 0.0, buckets_ = 0.0;
  std::size_t last_ = 0;               // n - 2
  bool uniform_ = false;               // evenly spaced: bucket k is segment k
  std::vector<std::uint32_t> bucket_;  // otherwise: first segment that can hold a u of bucket k
};

enum class Extrapolation { kLinear, kHold };

class Table1d {
 public:
  Table1d() = default;
  Table1d(std::vector<double> x, std::vector<double> y, Extrapolation extrapolation);

  // Run phase: no allocation.
  double operator()(double u) const {
    if (extrapolation_ == Extrapolation::kHold) {
      if (u <= x_.front()) return y_.front();
      if (u >= x_.back()) return y_.back();
    }
    const std::size_t i = index_.segment(x_.data(), u);
    return y_[i] + slope_[i] * (u - x_[i]);
  }

  bool empty() const { return x_.empty(); }
  const std::vector<double>& x() const { return x_; }
  const std::vector<double>& y() const { return y_; }
  Extrapolation extrapolation() const { return extrapolation_; }

 private:
  std::vector<double> x_, y_;
  Extrapolation extrapolation_ = Extrapolation::kLinear;
  AxisIndex index_;
  // (y[i+1] - y[i]) / (x[i+1] - x[i]); on a zero-length segment (a step) 0, and the segment
  // is never chosen for u inside the axis because the scan moves past repeated values
  std::vector<double> slope_;
};

// At least two rows, finite values, x non-decreasing (repeats allowed when
// allow_repeats, e.g. a cycle's time stamps) or strictly increasing.
void validate(const Table1d& t, const std::string& field, bool allow_repeats, Problems& problems);

class Table2d {
 public:
  Table2d() = default;
  // values are row-major: values[i * u2.size() + j] belongs to (u1[i], u2[j]).
  Table2d(std::vector<double> u1, std::vector<double> u2, std::vector<double> values);

  // Run phase: no allocation.
  double operator()(double a, double b) const {
    const std::size_t n2 = u2_.size();
    const std::size_t i = index1_.segment(u1_.data(), a);
    const std::size_t j = index2_.segment(u2_.data(), b);
    // unclamped fractions give linear extrapolation from the last two grid lines
    const double ta = (a - u1_[i]) * inv_du1_[i];
    const double tb = (b - u2_[j]) * inv_du2_[j];
    const double* r0 = v_.data() + i * n2 + j;
    const double* r1 = r0 + n2;
    const double lo = r0[0] + tb * (r0[1] - r0[0]);
    const double hi = r1[0] + tb * (r1[1] - r1[0]);
    return lo + ta * (hi - lo);
  }

  bool empty() const { return u1_.empty(); }
  const std::vector<double>& u1() const { return u1_; }
  const std::vector<double>& u2() const { return u2_; }
  const std::vector<double>& values() const { return v_; }

 private:
  std::vector<double> u1_, u2_, v_;
  AxisIndex index1_, index2_;
  std::vector<double> inv_du1_, inv_du2_;  // 1 / grid spacing, so a lookup has no division
};

// At least 2 x 2, strictly increasing axes, finite values, values.size() = n1 * n2.
void validate(const Table2d& t, const std::string& field, Problems& problems);

}  // namespace ehpt::plant
