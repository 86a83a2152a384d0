// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Fixed-step integrators over a plant (STYLE.md §6; the contract: solvers/plant.hpp).
// Modes and inputs are held constant over a step. Both integrators own their scratch, so a
// step allocates nothing, and neither throws: failures come back in IntegratorStatus.

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include <Eigen/Core>
#include <Eigen/LU>

#include "solvers/plant.hpp"

namespace ehpt::solvers {

struct IntegratorStatus {
  bool converged = true;  // implicit Euler: Newton met its tolerance within the cap
  int iterations = 0;     // Newton iterations (0 for RK4)
};

// Classical fourth-order Runge-Kutta.
template <class Plant>
  requires ::ehpt::solvers::OdeSystem<Plant>
class Rk4 {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  static constexpr int N = Plant::kNumStates;

  explicit Rk4(const Plant& plant) : plant_(&plant) {}
  // After a copy (a saved simulation state restored): the plant of the copy's owner.
  void rebind(const Plant& plant) { plant_ = &plant; }

  // Run phase: x(t_s) -> x(t_s + h_s). dx_start: dx/dt at (t_s, x, m, u) if the caller has it
  // (the first stage; the result is the same bit for bit), else null.
  IntegratorStatus step(double t_s, double h_s, const Modes& m, const Inputs& u, State& x,
                        const State* dx_start = nullptr) {
    const double half_s = 0.5 * h_s, sixth_s = h_s / 6.0;
    // the stages as locals, every loop unrolled at compile time (each): the values stay in
    // registers instead of a store and a reload per stage (measured: PSecu2 152 -> 140 ns per
    // step); each element gets the same operations in the same order, so the bits do not change
    State k1, k2, k3, k4, tmp;
    if (dx_start != nullptr) {
      each([&](auto i) __attribute__((always_inline)) { k1[i] = (*dx_start)[i]; });
    } else {
      plant_->derivatives(t_s, x, m, u, k1);
    }
    each([&](auto i) __attribute__((always_inline)) { tmp[i] = x[i] + half_s * k1[i]; });
    plant_->derivatives(t_s + half_s, tmp, m, u, k2);
    each([&](auto i) __attribute__((always_inline)) { tmp[i] = x[i] + half_s * k2[i]; });
    plant_->derivatives(t_s + half_s, tmp, m, u, k3);
    each([&](auto i) __attribute__((always_inline)) { tmp[i] = x[i] + h_s * k3[i]; });
    plant_->derivatives(t_s + h_s, tmp, m, u, k4);
    each([&](auto i) __attribute__((always_inline)) { x[i] += sixth_s * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]); });
    return {};
  }

 private:
  template <class F>
  [[gnu::always_inline]] static void each(F&& f) {
    [&]<int... I>(std::integer_sequence<int, I...>) __attribute__((always_inline)) { (f(std::integral_constant<int, I>{}), ...); }(
        std::make_integer_sequence<int, N>{});
  }

  const Plant* plant_;
};

namespace detail {

// Whether two Modes values are equal, for any plant, without memcmp (padding bytes) and
// without asking every plant for operator==: operator== where there is one; an empty struct
// is always equal; an aggregate of up to four fields (every plant's Modes) is compared field
// by field, recursively (a drive's Mode inside the EV's Modes). Anything else counts as
// changed, which costs a fresh Jacobian, never a wrong step.
struct AnyField {
  template <class T>
  operator T() const;  // declared only: used in unevaluated operands
};

template <class T, std::size_t... I>
constexpr bool brace_initialisable(std::index_sequence<I...>) {
  return requires { T{(static_cast<void>(I), AnyField{})...}; };
}

template <class T>
constexpr int field_count() {
  if constexpr (!std::is_aggregate_v<T>) {
    return -1;
  } else if constexpr (brace_initialisable<T>(std::make_index_sequence<5>{})) {
    return -1;  // five or more: not handled
  } else if constexpr (brace_initialisable<T>(std::make_index_sequence<4>{})) {
    return 4;
  } else if constexpr (brace_initialisable<T>(std::make_index_sequence<3>{})) {
    return 3;
  } else if constexpr (brace_initialisable<T>(std::make_index_sequence<2>{})) {
    return 2;
  } else if constexpr (brace_initialisable<T>(std::make_index_sequence<1>{})) {
    return 1;
  } else {
    return 0;
  }
}

template <class T>
bool same_modes(const T& a, const T& b) {
  if constexpr (std::is_empty_v<T>) {
    return true;
  } else if constexpr (std::equality_comparable<T>) {
    return a == b;
  } else if constexpr (field_count<T>() == 1) {
    const auto& [a0] = a;
    const auto& [b0] = b;
    return same_modes(a0, b0);
  } else if constexpr (field_count<T>() == 2) {
    const auto& [a0, a1] = a;
    const auto& [b0, b1] = b;
    return same_modes(a0, b0) && same_modes(a1, b1);
  } else if constexpr (field_count<T>() == 3) {
    const auto& [a0, a1, a2] = a;
    const auto& [b0, b1, b2] = b;
    return same_modes(a0, b0) && same_modes(a1, b1) && same_modes(a2, b2);
  } else if constexpr (field_count<T>() == 4) {
    const auto& [a0, a1, a2, a3] = a;
    const auto& [b0, b1, b2, b3] = b;
    return same_modes(a0, b0) && same_modes(a1, b1) && same_modes(a2, b2) && same_modes(a3, b3);
  } else {
    return false;
  }
}

}  // namespace detail

// Implicit (backward) Euler: solves g(x) = x - x0 - h f(t + h, x) = 0 by simplified Newton
// from the explicit Euler predictor x0 + h f(t, x0):
//   x <- x - M^-1 g(x),   M = I - h J,   J = df/dx by forward differences at a step's start,
// M inverted through PartialPivLU (fixed size, no heap). M is kept across steps (modified
// Newton): a step then costs one evaluation per iteration, plus one for the predictor unless
// the caller hands dx/dt at the start in (the runner does). The kept M is rebuilt
// (N + 1 evaluations less the audit-only columns, and an LU):
//   - at the first step, when the modes differ from those it was built with (compared field
//     by field, detail::same_modes), and for a step longer than the one it was built for;
//   - at the next step, after one that converged slowly on it (contraction theta >
//     kThetaRefresh, or more than kIterationsRefresh iterations);
//   - within a step, when the kept M contracts badly (theta > kThetaRedo, or no convergence in
//     kStaleIterations): the step is redone from the predictor on a fresh M (per-step Newton
//     as before, J at the step's start, the full iteration cap), so a kept M never fails a
//     step that a fresh one converges.
// The inputs are not compared (the EV's built-in ECU changes its command at every step): a
// command that changes J enough shows as a slower contraction, and the rules above rebuild M.
// A shorter step (the event stepper's partial steps, while locating an event and after it)
// tries the kept M, which contracts at about |h - h'| |J| / (1 + h |J|); if that is too slow,
// or the modes differ, it builds its own M in a second slot and leaves the kept one alone.
// Stopping: the update is within the tolerance, |dx_i| <= tol (1 + |x_i|) for every i, as
// before, and so is the error it leaves, estimated from the contraction (Hairer & Wanner,
// Solving ODEs II, IV.8): theta / (1 - theta) |dx| <= kKappa tol, theta = |dx_k| / |dx_k-1|
// in the scaled max norm (at the first iteration the last full step's theta on this M, 0 on a
// fresh M, whose first-iteration stop is then the old one). Per-step Newton converged so fast
// that its last update bounded its error; a kept M converges linearly, and the second test
// keeps the error left at a step below a tenth of the tolerance.
// IntegratorStatus: converged as before; iterations counts every Newton iteration, those of
// an attempt on a kept M that was abandoned included.
template <class Plant>
  requires ::ehpt::solvers::OdeSystem<Plant>
class ImplicitEuler {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  static constexpr int N = Plant::kNumStates;
  using Matrix = Eigen::Matrix<double, N, N>;

  static constexpr double kKappa = 0.1;          // error left at the stop / tolerance
  static constexpr double kThetaRedo = 0.5;      // kept M contracting slower: rebuild, redo the step
  static constexpr int kStaleIterations = 6;     // kept M not converged in this many: the same
  static constexpr double kThetaRefresh = 0.05;  // converged, but slower: rebuild at the next step
  static constexpr int kIterationsRefresh = 4;   // converged, but in more: the same

  explicit ImplicitEuler(const Plant& plant, int max_iterations = 20, double tolerance = 1e-10)
      : plant_(&plant), max_iterations_(max_iterations), tolerance_(tolerance) {
    if constexpr (requires { Plant::kAuditOnlyStates.size(); }) {
      for (const int i : Plant::kAuditOnlyStates) audit_only_[i] = true;
    }
    for (int j = 0; j < N; ++j) {
      if (!audit_only_[j]) active_[num_active_++] = j;
    }
  }

  // After a copy (a saved simulation state restored): the plant of the copy's owner.
  void rebind(const Plant& plant) { plant_ = &plant; }

  // Run phase: x(t_s) -> x(t_s + h_s). dx_start: dx/dt at (t_s, x, m, u) if the caller has it
  // (the predictor and the base of the differences), else null: one evaluation more.
  IntegratorStatus step(double t_s, double h_s, const Modes& m, const Inputs& u, State& x,
                        const State* dx_start = nullptr) {
    x0_ = x;
    if (dx_start != nullptr) {
      f0_ = *dx_start;
    } else {
      plant_->derivatives(t_s, x0_, m, u, f0_);
    }
    IntegratorStatus status{false, 0};
    const bool modes_kept = kept_.valid && detail::same_modes(m, kept_modes_);
    if (!kept_.valid || !(h_s < kept_.h_s * (1.0 - kSameStep))) {
      // a full step: on the kept matrix, rebuilt when stale, for a longer h or for other modes
      if (!modes_kept || refresh_due_ || h_s > kept_.h_s * (1.0 + kSameStep)) {
        refresh(t_s, h_s, m, u, kept_);
        newton(t_s, h_s, m, u, x, kept_, true, true, status);
      } else if (newton(t_s, h_s, m, u, x, kept_, false, true, status) == Outcome::kSlow) {
        refresh(t_s, h_s, m, u, kept_);
        newton(t_s, h_s, m, u, x, kept_, true, true, status);
      }
    } else if (!modes_kept || refresh_due_ ||
               newton(t_s, h_s, m, u, x, kept_, false, false, status) == Outcome::kSlow) {
      // a partial step that the kept matrix does not serve: a matrix of its own in the second
      // slot, the kept one left as it is for the full steps
      refresh(t_s, h_s, m, u, odd_);
      newton(t_s, h_s, m, u, x, odd_, true, false, status);
    }
    return status;
  }

  // Jacobian rebuilds so far (each N + 1 evaluations less the audit-only columns, and an LU).
  std::int64_t refreshes() const { return refreshes_; }

 private:
  enum class Outcome { kConverged, kSlow, kFailed };
  // An iteration matrix: (I - h J)^-1, the h it is for, and the last contraction seen on it.
  // Kept as the inverse: an iteration multiplies by its columns (plain loops over the fixed
  // size, the audit-only ones skipped), which measured faster than Eigen's triangular solves
  // at these sizes; the matrix approximates the Newton matrix anyway, the iteration corrects.
  struct Slot {
    Matrix inverse;
    double h_s = 0.0;
    double theta = 0.0;
    bool valid = false;
  };
  static constexpr double kSameStep = 1e-6;  // t_(n+1) - t_n differs from h in the last bits

  // Run phase: J at (t_s, x0_) with f0_ as its base, by forward differences. A state no
  // derivative reads (an energy integral, kept for the audit: Plant::kAuditOnlyStates,
  // optional) has a column of exact zeros, as the difference would give it: skipped.
  void refresh(double t_s, double h_s, const Modes& m, const Inputs& u, Slot& slot) {
    for (int j = 0; j < N; ++j) {
      if (audit_only_[j]) {
        jac_.col(j).setZero();
        continue;
      }
      xp_ = x0_;
      const double delta = 1.5e-8 * std::max(1.0, std::abs(x0_[j]));
      xp_[j] += delta;
      plant_->derivatives(t_s, xp_, m, u, fp_);
      jac_.col(j) = -h_s * (fp_ - f0_) / delta;
    }
    jac_ += Matrix::Identity();
    lu_.compute(jac_);
    slot.inverse = lu_.inverse();
    slot.h_s = h_s;
    slot.theta = 0.0;
    slot.valid = true;
    if (&slot == &kept_) {
      kept_modes_ = m;
      refresh_due_ = false;
    }
    ++refreshes_;
  }

  // Run phase: simplified Newton from the explicit Euler predictor on the slot's matrix. A
  // kept (not fresh) matrix gives up early, as kSlow, when it contracts badly. learn: a full
  // step; its contraction is kept for the next step's first iteration and may call for a
  // refresh (a partial step's, on a matrix made for another h, says nothing about the next).
  Outcome newton(double t_s, double h_s, const Modes& m, const Inputs& u, State& x, Slot& slot, bool fresh,
                 bool learn, IntegratorStatus& status) {
    const double t1_s = t_s + h_s;
    for (int i = 0; i < N; ++i) x[i] = x0_[i] + h_s * f0_[i];
    const int cap = fresh ? max_iterations_ : std::min(kStaleIterations, max_iterations_);
    double s_prev = 0.0, theta = slot.theta;
    for (int it = 1; it <= cap; ++it) {
      plant_->derivatives(t1_s, x, m, u, f_);
      // dx = M^-1 g in plain loops over the fixed size, on local arrays (no aliasing). An
      // audit-only state's column of M is the unit column, and so is its column of M^-1.
      std::array<double, N> g, dx;
      for (int i = 0; i < N; ++i) {
        g[i] = x[i] - x0_[i] - h_s * f_[i];
        dx[i] = audit_only_[i] ? g[i] : 0.0;
      }
      for (int a = 0; a < num_active_; ++a) {
        const int j = active_[a];
        for (int i = 0; i < N; ++i) dx[i] += slot.inverse(i, j) * g[j];
      }
      // the update's size, scaled as the tolerance: max |dx_i| / (1 + |x_i|)
      double s = 0.0;
      for (int i = 0; i < N; ++i) {
        x[i] -= dx[i];
        s = std::max(s, std::abs(dx[i]) / (1.0 + std::abs(x[i])));
      }
      ++status.iterations;
      if (it > 1) theta = s_prev > 0.0 ? s / s_prev : 0.0;
      // remaining error about theta / (1 - theta) s; theta >= 1/2 (or roundoff) caps the factor at 1
      const double eta = theta < 0.5 ? theta / (1.0 - theta) : 1.0;
      if (s <= tolerance_ && eta * s <= kKappa * tolerance_) {
        status.converged = true;
        if (learn) {
          slot.theta = theta;
          refresh_due_ = theta > kThetaRefresh || it > kIterationsRefresh;
        }
        return Outcome::kConverged;
      }
      if (!fresh && it > 1 && !(theta <= kThetaRedo)) return Outcome::kSlow;  // NaN included
      s_prev = s;
    }
    status.converged = false;
    return fresh ? Outcome::kFailed : Outcome::kSlow;
  }

  const Plant* plant_;
  int max_iterations_;
  double tolerance_;
  State x0_, xp_, f0_, f_, fp_;
  std::array<bool, N> audit_only_{};  // no derivative reads these states
  std::array<int, N> active_{};       // the others
  int num_active_ = 0;
  Matrix jac_;
  Eigen::PartialPivLU<Matrix> lu_;
  Slot kept_, odd_;        // the full-step matrix kept across steps; one for partial steps
  Modes kept_modes_{};     // the modes kept_ was built with
  bool refresh_due_ = false;
  std::int64_t refreshes_ = 0;
};

}  // namespace ehpt::solvers
