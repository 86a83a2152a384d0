#pragma once
// Fixed-step integrators over a plant (STYLE.md §6; the contract: solvers/plant.hpp).
// Modes and inputs are held constant over a step. Both integrators own their scratch, so a
// step allocates nothing, and neither throws: failures come back in IntegratorStatus.

#include <algorithm>
#include <array>
#include <cmath>

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

  explicit Rk4(const Plant& plant) : plant_(plant) {}

  // Run phase: x(t_s) -> x(t_s + h_s). dx_start: dx/dt at (t_s, x, m, u) if the caller has it
  // (the first stage; the result is the same bit for bit), else null.
  IntegratorStatus step(double t_s, double h_s, const Modes& m, const Inputs& u, State& x,
                        const State* dx_start = nullptr) {
    const double half_s = 0.5 * h_s, sixth_s = h_s / 6.0;
    // plain loops over the fixed size: GCC does not inline Eigen's assignment loops here
    if (dx_start != nullptr) {
      k1_ = *dx_start;
    } else {
      plant_.derivatives(t_s, x, m, u, k1_);
    }
    for (int i = 0; i < N; ++i) tmp_[i] = x[i] + half_s * k1_[i];
    plant_.derivatives(t_s + half_s, tmp_, m, u, k2_);
    for (int i = 0; i < N; ++i) tmp_[i] = x[i] + half_s * k2_[i];
    plant_.derivatives(t_s + half_s, tmp_, m, u, k3_);
    for (int i = 0; i < N; ++i) tmp_[i] = x[i] + h_s * k3_[i];
    plant_.derivatives(t_s + h_s, tmp_, m, u, k4_);
    for (int i = 0; i < N; ++i) x[i] += sixth_s * (k1_[i] + 2.0 * (k2_[i] + k3_[i]) + k4_[i]);
    return {};
  }

 private:
  const Plant& plant_;
  State k1_, k2_, k3_, k4_, tmp_;
};

// Implicit (backward) Euler: solves g(x) = x - x0 - h f(t + h, x) = 0 by Newton.
// The Jacobian dg/dx = I - h df/dx is built by forward differences once per step and
// factorised with PartialPivLU (fixed size, no heap); the iteration is capped.
template <class Plant>
  requires ::ehpt::solvers::OdeSystem<Plant>
class ImplicitEuler {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  static constexpr int N = Plant::kNumStates;
  using Matrix = Eigen::Matrix<double, N, N>;

  explicit ImplicitEuler(const Plant& plant, int max_iterations = 20, double tolerance = 1e-10)
      : plant_(plant), max_iterations_(max_iterations), tolerance_(tolerance) {
    if constexpr (requires { Plant::kAuditOnlyStates.size(); }) {
      for (const int i : Plant::kAuditOnlyStates) audit_only_[i] = true;
    }
  }

  // Run phase: x(t_s) -> x(t_s + h_s). dx_start (dx/dt at the start) is not used: the
  // implicit step evaluates at the end of the step.
  IntegratorStatus step(double t_s, double h_s, const Modes& m, const Inputs& u, State& x,
                        const State* /*dx_start*/ = nullptr) {
    const double t1_s = t_s + h_s;
    x0_ = x;
    // Jacobian of f at the start point, by forward differences. A state no derivative reads
    // (an energy integral, kept for the audit: Plant::kAuditOnlyStates, optional) has a
    // column of exact zeros, as the difference would give it: skipped, same bits.
    plant_.derivatives(t1_s, x0_, m, u, f_);
    for (int j = 0; j < N; ++j) {
      if (audit_only_[j]) {
        jac_.col(j).setZero();
        continue;
      }
      xp_ = x0_;
      const double delta = 1.5e-8 * std::max(1.0, std::abs(x0_[j]));
      xp_[j] += delta;
      plant_.derivatives(t1_s, xp_, m, u, fp_);
      jac_.col(j) = -h_s * (fp_ - f_) / delta;
    }
    jac_ += Matrix::Identity();
    lu_.compute(jac_);
    // Newton from the explicit Euler predictor
    x = x0_ + h_s * f_;
    IntegratorStatus status{false, 0};
    for (int it = 1; it <= max_iterations_; ++it) {
      plant_.derivatives(t1_s, x, m, u, f_);
      g_ = x - x0_ - h_s * f_;
      dx_ = lu_.solve(g_);
      x -= dx_;
      status.iterations = it;
      bool small = true;
      for (int i = 0; i < N; ++i) small = small && std::abs(dx_[i]) <= tolerance_ * (1.0 + std::abs(x[i]));
      if (small) {
        status.converged = true;
        break;
      }
    }
    return status;
  }

 private:
  const Plant& plant_;
  int max_iterations_;
  double tolerance_;
  State x0_, xp_, f_, fp_, g_, dx_;
  std::array<bool, N> audit_only_{};  // no derivative reads these states
  Matrix jac_;
  Eigen::PartialPivLU<Matrix> lu_;
};

}  // namespace ehpt::solvers
