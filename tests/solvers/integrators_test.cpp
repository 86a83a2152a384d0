// Orders of convergence measured on problems with known solutions, and stiffness.
#include "solvers/integrators.hpp"

#include <cstddef>

#include "plant/bev_plant.hpp"
#include "plant/psd_plant.hpp"
#include "test_plants.hpp"

#include <gtest/gtest.h>

#include <cmath>

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
  const auto& p = std::get<ehpt::plant::PsdParams>(sc.plant);
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
