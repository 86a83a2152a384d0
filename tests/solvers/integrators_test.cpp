// SPDX-License-Identifier: BSD-3-Clause
// Orders of convergence measured on problems with known solutions, and stiffness.
#include "solvers/integrators.hpp"

#include <cstddef>
#include <cstdint>

#include "plant/bev_plant.hpp"
#include "plant/psd_plant.hpp"
#include "test_plants.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <concepts>

namespace ehpt::solvers {
namespace {

// Harmonic oscillator with damping: x'' + 2 z w x' + w^2 x = 0 (nonzero, smooth, 2 states).
struct Oscillator {
  static constexpr int kNumStates = 2;
  using State = Eigen::Matrix<double, 2, 1>;
  struct Modes {};
  struct Inputs {};
  double w = 2.0, zeta = 0.1;
  void derivatives(double, const State& x, const Modes&, const Inputs&, State& dx) const {
    dx << x[1], -2.0 * zeta * w * x[1] - w * w * x[0];
  }
  double exact(double t) const {  // x(0) = 1, x'(0) = 0
    const double wd = w * std::sqrt(1.0 - zeta * zeta);
    return std::exp(-zeta * w * t) * (std::cos(wd * t) + zeta * w / wd * std::sin(wd * t));
  }
};

// Nonlinear, time-dependent scalar: y' = -y^2 + t, checked against a fine RK4 reference
// is avoided: use y' = y cos t, y = exp(sin t).
struct Periodic {
  static constexpr int kNumStates = 1;
  using State = Eigen::Matrix<double, 1, 1>;
  struct Modes {};
  struct Inputs {};
  void derivatives(double t, const State& x, const Modes&, const Inputs&, State& dx) const {
    dx[0] = x[0] * std::cos(t);
  }
};

template <template <class> class Method, class Plant, class Exact>
double error_at(const Plant& plant, typename Plant::State x, double t_end, int steps, Exact exact) {
  Method<Plant> method(plant);
  const double h = t_end / steps;
  for (int n = 0; n < steps; ++n) method.step(n * h, h, {}, {}, x);
  return std::abs(x[0] - exact(t_end));
}

TEST(Rk4, IsFourthOrder) {
  const Oscillator osc;
  const Oscillator::State x0(1.0, 0.0);
  const auto exact = [&](double t) { return osc.exact(t); };
  const double e1 = error_at<Rk4>(osc, x0, 5.0, 200, exact);
  const double e2 = error_at<Rk4>(osc, x0, 5.0, 400, exact);
  EXPECT_NEAR(std::log2(e1 / e2), 4.0, 0.15);
  const Periodic per;
  const auto exact_p = [](double t) { return std::exp(std::sin(t)); };
  const double p1 = error_at<Rk4>(per, Periodic::State(1.0), 6.0, 100, exact_p);
  const double p2 = error_at<Rk4>(per, Periodic::State(1.0), 6.0, 200, exact_p);
  EXPECT_NEAR(std::log2(p1 / p2), 4.0, 0.2);
}

TEST(ImplicitEuler, IsFirstOrder) {
  const Oscillator osc;
  const auto exact = [&](double t) { return osc.exact(t); };
  const double e1 = error_at<ImplicitEuler>(osc, Oscillator::State(1.0, 0.0), 5.0, 4000, exact);
  const double e2 = error_at<ImplicitEuler>(osc, Oscillator::State(1.0, 0.0), 5.0, 8000, exact);
  EXPECT_NEAR(std::log2(e1 / e2), 1.0, 0.05);
  const Periodic per;
  const auto exact_p = [](double t) { return std::exp(std::sin(t)); };
  const double p1 = error_at<ImplicitEuler>(per, Periodic::State(1.0), 6.0, 2000, exact_p);
  const double p2 = error_at<ImplicitEuler>(per, Periodic::State(1.0), 6.0, 4000, exact_p);
  EXPECT_NEAR(std::log2(p1 / p2), 1.0, 0.05);
}

// x' = A x with eigenvalues -1 and -1e4: at h = 1 ms, h lambda = -10 is far outside RK4's
// stability region (about -2.79 on the real axis); implicit Euler is A-stable.
struct Stiff {
  static constexpr int kNumStates = 2;
  using State = Eigen::Matrix<double, 2, 1>;
  struct Modes {};
  struct Inputs {};
  void derivatives(double, const State& x, const Modes&, const Inputs&, State& dx) const {
    dx << -x[0] + x[1], -1e4 * x[1];
  }
};

TEST(ImplicitEuler, StableOnAStiffSystemWhereRk4Diverges) {
  const Stiff plant;
  Rk4<Stiff> rk4(plant);
  ImplicitEuler<Stiff> ie(plant);
  Stiff::State xr(1.0, 1.0), xi(1.0, 1.0);
  const double h = 1e-3;
  bool converged = true;
  for (int n = 0; n < 1000; ++n) {
    rk4.step(n * h, h, {}, {}, xr);
    converged = converged && ie.step(n * h, h, {}, {}, xi).converged;
  }
  EXPECT_TRUE(converged);
  EXPECT_FALSE(std::abs(xr[1]) < 1e3);  // diverged (or overflowed to inf)
  EXPECT_LT(std::abs(xi[1]), 1e-6);
  // slow component: x0' = -x0 + x1 with x1 -> 0 quickly: x0(1) ~ exp(-1), first order
  EXPECT_NEAR(xi[0], std::exp(-1.0), 2e-3);
}

TEST(ImplicitEuler, ReportsNewtonFailureInsteadOfThrowing) {
  Oscillator osc;
  ImplicitEuler<Oscillator> ie(osc, /*max_iterations=*/1, /*tolerance=*/1e-300);
  Oscillator::State x(1.0, 0.0);
  const IntegratorStatus s = ie.step(0.0, 0.1, {}, {}, x);
  EXPECT_FALSE(s.converged);
  EXPECT_EQ(s.iterations, 1);
}

// Kept Jacobian (modified Newton). A damped pendulum whose gain the modes set and whose
// stiffness an input sets; it counts its evaluations. Its Modes has no operator==: the
// integrator compares it field by field, the nested struct too.
struct Pendulum {
  static constexpr int kNumStates = 2;
  using State = Eigen::Matrix<double, 2, 1>;
  enum class Gear { kLow, kHigh };
  struct Modes {
    Gear gear = Gear::kLow;
    struct Lock {
      bool on = false;
    } lock{};
  };
  struct Inputs {
    double stiffness = 1.0;
  };
  mutable int evaluations = 0;
  void derivatives(double, const State& x, const Modes& m, const Inputs& u, State& dx) const {
    ++evaluations;
    const double k = (m.gear == Gear::kHigh ? 4.0 : 1.0) * u.stiffness;
    dx << x[1], -k * std::sin(x[0]) - (m.lock.on ? 50.0 : 0.5) * x[1];
  }
};

TEST(ImplicitEuler, ComparesModesFieldByFieldWithoutOperatorEquals) {
  static_assert(!std::equality_comparable<Pendulum::Modes>);
  Pendulum::Modes a, b;
  EXPECT_TRUE(detail::same_modes(a, b));
  b.gear = Pendulum::Gear::kHigh;
  EXPECT_FALSE(detail::same_modes(a, b));
  b = a;
  b.lock.on = true;  // in the nested struct
  EXPECT_FALSE(detail::same_modes(a, b));
  EXPECT_TRUE(detail::same_modes(Oscillator::Modes{}, Oscillator::Modes{}));  // empty: always equal
}

TEST(ImplicitEuler, KeepsTheJacobianAcrossSteps) {
  const Pendulum plant;
  ImplicitEuler<Pendulum> ie(plant);
  Pendulum::State x(1.0, 0.0);
  const double h = 1e-3;
  ASSERT_TRUE(ie.step(0.0, h, {}, {}, x).converged);
  // the first step: predictor, the two columns, the iterations
  EXPECT_EQ(ie.refreshes(), 1);
  EXPECT_GE(plant.evaluations, 4);
  plant.evaluations = 0;
  int iterations = 0;
  for (int n = 1; n <= 2000; ++n) {
    const IntegratorStatus s = ie.step(n * h, h, {}, {}, x);
    ASSERT_TRUE(s.converged) << n;
    iterations += s.iterations;
  }
  EXPECT_EQ(ie.refreshes(), 1);                     // the same matrix over 2 s of swinging
  EXPECT_EQ(plant.evaluations, 2000 + iterations);  // one predictor and one per iteration
  EXPECT_LE(plant.evaluations, 3 * 2000);           // where per-step Newton took 3 + iterations
  // with dx/dt at the start handed in (as the runner does), the predictor is free too
  Pendulum::State dx;
  plant.derivatives(2001 * h, x, {}, {}, dx);
  plant.evaluations = 0;
  const IntegratorStatus s = ie.step(2001 * h, h, {}, {}, x, &dx);
  EXPECT_EQ(plant.evaluations, s.iterations);
}

TEST(ImplicitEuler, RefreshesTheJacobianOnAModeSwitch) {
  const Pendulum plant;
  ImplicitEuler<Pendulum> ie(plant);
  Pendulum::State x(1.0, 0.0);
  const double h = 1e-3;
  Pendulum::Modes m;
  int n = 0;
  const auto run = [&](int steps) {
    for (int i = 0; i < steps; ++i, ++n) ASSERT_TRUE(ie.step(n * h, h, m, {}, x).converged);
  };
  run(10);
  EXPECT_EQ(ie.refreshes(), 1);
  m.gear = Pendulum::Gear::kHigh;
  run(1);
  EXPECT_EQ(ie.refreshes(), 2);  // at the switch
  run(10);
  EXPECT_EQ(ie.refreshes(), 2);  // not after it
  m.lock.on = true;              // a field of the nested struct
  run(10);
  EXPECT_EQ(ie.refreshes(), 3);
  const Pendulum::Modes same = m;  // a copy: equal, nothing to rebuild
  for (int i = 0; i < 10; ++i, ++n) ASSERT_TRUE(ie.step(n * h, h, same, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 3);
}

// The event stepper's partial steps (h' < h) must not cost the full steps their matrix. On the
// stiff system (h lambda = -10) the matrix for h contracts at about (h - h') lambda / (1 + h
// lambda) on a step of h' = h / 4: too slow, so the partial step builds its own, in a second
// slot; the full steps after it go on with the kept one. A longer step rebuilds the kept one.
TEST(ImplicitEuler, KeepsTheFullStepMatrixOverPartialStepsAndRebuildsItForALongerStep) {
  const Stiff plant;
  ImplicitEuler<Stiff> ie(plant);
  Stiff::State x(1.0, 1.0);
  const double h = 1e-3;
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(ie.step(n * h, h, {}, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 1);
  // a partial step: its own matrix, the exact implicit Euler step
  const Stiff::State x0 = x;
  ASSERT_TRUE(ie.step(5 * h, 0.25 * h, {}, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 2);
  Eigen::Matrix2d a;
  a << -1.0, 1.0, 0.0, -1e4;
  const Stiff::State exact = (Eigen::Matrix2d::Identity() - 0.25 * h * a).inverse() * x0;
  EXPECT_NEAR(x[0], exact[0], 1e-10 * (1.0 + std::abs(exact[0])));
  EXPECT_NEAR(x[1], exact[1], 1e-10 * (1.0 + std::abs(exact[1])));
  // the full steps after it: the kept matrix, untouched
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(ie.step(5.25 * h + n * h, h, {}, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 2);
  // a longer step: rebuilt
  ASSERT_TRUE(ie.step(10.25 * h, 2.0 * h, {}, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 3);
}

// On a slowly stiff system a partial step contracts well enough on the kept matrix: no rebuild.
TEST(ImplicitEuler, APartialStepUsesTheKeptMatrixWhenItContractsWell) {
  const Pendulum plant;
  ImplicitEuler<Pendulum> ie(plant);
  Pendulum::State x(1.0, 0.0);
  const double h = 1e-3;
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(ie.step(n * h, h, {}, {}, x).converged);
  ASSERT_TRUE(ie.step(5 * h, 0.3 * h, {}, {}, x).converged);
  ASSERT_TRUE(ie.step(5.3 * h, 0.7 * h, {}, {}, x).converged);
  EXPECT_EQ(ie.refreshes(), 1);
}

// x' = -a x with a an input (the integrator does not compare inputs). a jumps from 1 to 1e5
// (h a = 100): the kept matrix, 1 + h, would diverge (each iteration multiplies the error by
// about -100); the step sees the contraction, rebuilds, redoes the step and converges to
// the implicit Euler solution x0 / (1 + h a). A change that the kept matrix converges on,
// slowly, rebuilds it from the next step on.
struct Decay {
  static constexpr int kNumStates = 1;
  using State = Eigen::Matrix<double, 1, 1>;
  struct Modes {};
  struct Inputs {
    double rate_1_s = 1.0;
  };
  void derivatives(double, const State& x, const Modes&, const Inputs& u, State& dx) const {
    dx[0] = -u.rate_1_s * x[0];
  }
};

TEST(ImplicitEuler, RebuildsAndRedoesAStepThatTheKeptMatrixWouldNotConverge) {
  const Decay plant;
  ImplicitEuler<Decay> ie(plant);
  const double h = 1e-3;
  Decay::State x(1.0);
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(ie.step(n * h, h, {}, {1.0}, x).converged);
  ASSERT_EQ(ie.refreshes(), 1);
  const double x0 = x[0];
  const IntegratorStatus s = ie.step(5 * h, h, {}, {1e5}, x);
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(ie.refreshes(), 2);
  EXPECT_NEAR(x[0], x0 / (1.0 + h * 1e5), 1e-12);
  // the rebuilt matrix fits the steps after it
  for (int n = 6; n < 10; ++n) ASSERT_TRUE(ie.step(n * h, h, {}, {1e5}, x).converged);
  EXPECT_EQ(ie.refreshes(), 2);
}

TEST(ImplicitEuler, RebuildsAfterAStepThatConvergedSlowly) {
  const Decay plant;
  ImplicitEuler<Decay> ie(plant);
  const double h = 1e-3;
  Decay::State x(1e-6);  // small: the predictor is close, so the slow iteration still converges
  for (int n = 0; n < 5; ++n) ASSERT_TRUE(ie.step(n * h, h, {}, {1.0}, x).converged);
  ASSERT_EQ(ie.refreshes(), 1);
  const IntegratorStatus s = ie.step(5 * h, h, {}, {100.0}, x);  // contraction about h a / (1 + h) = 0.1
  EXPECT_TRUE(s.converged);
  EXPECT_GT(s.iterations, 2);
  EXPECT_EQ(ie.refreshes(), 1);  // converged on the kept matrix, no redo
  ASSERT_TRUE(ie.step(6 * h, h, {}, {100.0}, x).converged);
  EXPECT_EQ(ie.refreshes(), 2);  // rebuilt for the next step
}

// The stop on a linearly converging iteration. A partial step of 0.6 h on the matrix kept for
// h (h a = 1) contracts at exactly theta = 0.4 h a / (1 + h a) = 0.2, so the error left after
// an update dx is theta / (1 - theta) |dx| = |dx| / 4: stopping at |dx| <= tol alone leaves up
// to a quarter of the tolerance (measured 0.25); the contraction-based stop, a tenth.
TEST(ImplicitEuler, ALinearlyConvergingStepStopsWithATenthOfTheToleranceLeft) {
  const Decay plant;
  const double h = 1e-3, tol = 1e-10;
  double worst = 0.0;
  std::int64_t refreshes = 0;
  for (int k = 0; k < 200; ++k) {
    ImplicitEuler<Decay> ie(plant);
    Decay::State x(1.0);
    ASSERT_TRUE(ie.step(0.0, h, {}, {1000.0}, x).converged);  // the matrix for h
    x[0] = 1e-7 * std::pow(10.0, k / 100.0);  // small: the kept matrix converges within its cap
    const double exact = x[0] / (1.0 + 0.6 * h * 1000.0);
    ASSERT_TRUE(ie.step(h, 0.6 * h, {}, {1000.0}, x).converged);
    refreshes += ie.refreshes() - 1;
    worst = std::max(worst, std::abs(x[0] - exact) / (tol * (1.0 + std::abs(exact))));
  }
  EXPECT_LT(refreshes, 150);  // most of the 200 partial steps converged on the kept matrix
  EXPECT_LT(worst, 0.101);
}

// Accuracy: a forced linear system x' = A(u) x + b(t) whose matrix drifts with an input at
// every step, so the kept Jacobian is always somewhat off and the iteration converges
// linearly. Each step stays within the tolerance of the exact implicit Euler step
// (I - h A)^-1 (x_n + h b(t_n+1)), as per-step Newton did, with the matrix rebuilt only now and then.
struct Drifting {
  static constexpr int kNumStates = 2;
  using State = Eigen::Matrix<double, 2, 1>;
  struct Modes {};
  struct Inputs {
    double u = 0.0;
  };
  static Eigen::Matrix2d a(double u) {
    Eigen::Matrix2d m;
    m << -1.0, 3.0, -3.0 - 20.0 * u, -10.0 - 40.0 * u;
    return m;
  }
  static State b(double t) { return State(10.0 * std::sin(t), 10.0 * std::cos(3.0 * t)); }
  void derivatives(double t, const State& x, const Modes&, const Inputs& in, State& dx) const {
    dx = a(in.u) * x + b(t);
  }
};

TEST(ImplicitEuler, StaysWithinTheToleranceOfTheExactStepOnAKeptMatrix) {
  const Drifting plant;
  ImplicitEuler<Drifting> ie(plant);
  const double h = 0.01, tol = 1e-10;
  Drifting::State x(1.0, -2.0);
  double worst = 0.0;  // error / (tol (1 + |x|)), over components and steps
  int iterations = 0;
  for (int n = 0; n < 2000; ++n) {
    const Drifting::Inputs u{0.5 + 0.5 * std::sin(0.003 * n)};
    const Drifting::State exact =
        (Eigen::Matrix2d::Identity() - h * Drifting::a(u.u)).inverse() * (x + h * Drifting::b((n + 1) * h));
    const IntegratorStatus s = ie.step(n * h, h, {}, u, x);
    ASSERT_TRUE(s.converged) << n;
    iterations += s.iterations;
    for (int i = 0; i < 2; ++i) worst = std::max(worst, std::abs(x[i] - exact[i]) / (tol * (1.0 + std::abs(exact[i]))));
  }
  EXPECT_LT(worst, 0.1);            // a tenth of the tolerance: the contraction-based stop
  EXPECT_LT(ie.refreshes(), 100);   // kept over most steps (56 of 2000 steps rebuild it)
  EXPECT_GT(iterations, 3 * 2000);  // linear convergence: more than per-step Newton's two
}

}  // namespace
}  // namespace ehpt::solvers

// Implicit Euler skips the Jacobian columns of the states no derivative reads
// (Plant::kAuditOnlyStates): the same steps, bit for bit, as with every column differenced.
namespace {
struct BevWithEveryColumn : ehpt::plant::BevPlant {
  using ehpt::plant::BevPlant::BevPlant;
  static constexpr std::nullptr_t kAuditOnlyStates = nullptr;  // hides the EV's list
};
}  // namespace

TEST(ImplicitEuler, SkippingAuditOnlyColumnsChangesNoBit) {
  using ehpt::plant::BevPlant;
  static_assert(BevPlant::kAuditOnlyStates.size() == 6);
  const BevPlant marked(ehpt::test::mbev("data/cycles/cycle_nedc.csv"));
  const BevWithEveryColumn every(ehpt::test::mbev("data/cycles/cycle_nedc.csv"));
  ehpt::solvers::ImplicitEuler<BevPlant> a(marked);
  ehpt::solvers::ImplicitEuler<BevWithEveryColumn> b(every);
  BevPlant::State xa = marked.initial_state();
  xa[BevPlant::kSpeed] = 12.0;
  BevPlant::State xb = xa;
  const BevPlant::Modes m{ehpt::plant::Motion::kForward};
  ehpt::msgs::EvCommand u;
  for (int n = 0; n < 20000; ++n) {
    u.driveTauRef_Nm = 60.0 * std::sin(1e-3 * n);  // drive and brake, the battery both ways
    a.step(1e-3 * n, 1e-3, m, u, xa);
    b.step(1e-3 * n, 1e-3, m, u, xb);
    for (int i = 0; i < BevPlant::kNumStates; ++i) ASSERT_EQ(xa[i], xb[i]) << "step " << n << " state " << i;
  }
  EXPECT_GT(xa[BevPlant::kBatteryOutJ], 0.0);  // the integrals did integrate
  EXPECT_GT(xa[BevPlant::kDistance], 100.0);
}

// The same for the paper's hybrid: 9 of its 14 states are audit-only (fuel included).
namespace {
struct PsdWithEveryColumn : ehpt::plant::PsdPlant {
  using ehpt::plant::PsdPlant::PsdPlant;
  static constexpr std::nullptr_t kAuditOnlyStates = nullptr;
};
}  // namespace

TEST(ImplicitEuler, SkippingAuditOnlyColumnsChangesNoBitInTheHybrid) {
  using ehpt::plant::PsdPlant;
  const ehpt::hil::Scenario sc = ehpt::test::load(ehpt::test::source_path("scenarios/psecu2_nedc.toml"));
  const auto& p = sc.plant.get<ehpt::plant::PsdParams>();
  const PsdPlant marked(p);
  const PsdWithEveryColumn every(p);
  ehpt::solvers::ImplicitEuler<PsdPlant> a(marked);
  ehpt::solvers::ImplicitEuler<PsdWithEveryColumn> b(every);
  PsdPlant::State xa = marked.initial_state();
  xa[PsdPlant::kIceSpeed] = 150.0;
  xa[PsdPlant::kRingSpeed] = 200.0;
  PsdPlant::State xb = xa;
  const PsdPlant::Modes m = marked.initial_modes(xa);
  ehpt::msgs::PsdCommand u;
  for (int n = 0; n < 20000; ++n) {
    u.icePowRef_W = 15000.0 + 10000.0 * std::sin(1e-3 * n);  // the engine running, its fuel flowing
    u.iceON = true;
    u.motTauRef_Nm = 40.0 * std::sin(2e-3 * n);
    a.step(1e-3 * n, 1e-3, m, u, xa);
    b.step(1e-3 * n, 1e-3, m, u, xb);
    for (int i = 0; i < PsdPlant::kNumStates; ++i) ASSERT_EQ(xa[i], xb[i]) << "step " << n << " state " << i;
  }
  EXPECT_GT(xa[PsdPlant::kFuelKg], 0.0);
}
