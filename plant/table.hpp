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

// Finds the segment of a sorted axis in O(1): a uniform bucket grid built at start-up maps
// u to the first candidate segment, then a short forward scan finishes (repeats allowed).
class AxisIndex {
 public:
  AxisIndex() = default;
  explicit AxisIndex(const std::vector<double>& x);
  // Run phase: the last i with x[i] <= u, kept within [0, n-2].
  std::size_t segment(const std::vector<double>& x, double u) const {
    double k = (u - x0_) * inv_width_;
    if (!(k > 0.0)) return 0;  // below the axis (or NaN)
    const std::size_t last = x.size() - 2;
    if (k >= static_cast<double>(bucket_.size())) return last;
    std::size_t i = bucket_[static_cast<std::size_t>(k)];
    while (i < last && x[i + 1] <= u) ++i;
    return i;
  }

 private:
  double x0_ = 0.0, inv_width_ = 0.0;
  std::vector<std::uint32_t> bucket_;  // first segment that can hold a u of this bucket
};

enum class Extrapolation { kLinear, kHold };

class Table1d {
 public:
  Table1d() = default;
  Table1d(std::vector<double> x, std::vector<double> y, Extrapolation extrapolation);

  // Run phase: no allocation.
  double operator()(double x) const;

  bool empty() const { return x_.empty(); }
  const std::vector<double>& x() const { return x_; }
  const std::vector<double>& y() const { return y_; }
  Extrapolation extrapolation() const { return extrapolation_; }

 private:
  std::vector<double> x_, y_;
  Extrapolation extrapolation_ = Extrapolation::kLinear;
  AxisIndex index_;
  std::vector<double> slope_;  // (y[i+1] - y[i]) / (x[i+1] - x[i]); 0 on a zero-length segment
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
  double operator()(double u1, double u2) const;

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
