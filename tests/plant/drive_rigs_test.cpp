// SPDX-License-Identifier: BSD-3-Clause
// TestMBOneFlange (P15 §3, Figs. 11-13; MODELS.md §11.1) and TestTwoFlange (§11.3).
#include "plant/drive_rigs.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hil/config/config.hpp"
#include "solvers/event_stepper.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

DriveRigParams load_rig(const std::string& scenario) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  EXPECT_TRUE(hil::load_scenario(test::source_path(scenario), {}, sc, errors)) << (errors.empty() ? "" : errors[0]);
  return sc.plant.get<DriveRigParams>();
}

// Outputs every step of h over duration_s (t = 0 included).
std::vector<DriveRig::Outputs> simulate(const DriveRig& rig, double h_s, double duration_s,
                                        EnergyAudit* audit = nullptr) {
  solvers::Rk4<DriveRig> rk4(rig);
  solvers::EventStepper<DriveRig, solvers::Rk4<DriveRig>> stepper(rig, rk4, 0.0, h_s);
  DriveRig::State x = rig.initial_state();
  const DriveRig::State x0 = x;
  DriveRig::Modes m{};
  std::vector<DriveRig::Outputs> out;
  const auto steps = std::llround(duration_s / h_s);
  for (std::int64_t n = 0; n <= steps; ++n) {
    DriveRig::Outputs y;
    rig.outputs(stepper.time_s(n), x, m, {}, y);
    out.push_back(y);
    if (n < steps) stepper.advance(n, x, m, {});
  }
  if (audit != nullptr) *audit = rig.audit(x0, x);
  return out;
}

// First time at or after t_from at which pred holds.
template <class Pred>
double first_time(const std::vector<DriveRig::Outputs>& ys, double t_from, Pred pred) {
  for (const auto& y : ys) {
    if (y.time_s >= t_from && pred(y)) return y.time_s;
  }
  return -1.0;
}

TEST(TestMBOneFlange, ReproducesThePaper) {
  const DriveRig rig(load_rig("scenarios/one_flange_test.toml"));
  EnergyAudit audit;
  const auto ys = simulate(rig, 1e-3, 50.0, &audit);
  // t < 10 s: 20 N m delivered, torque-limited region (state 0)
  for (const auto& y : ys) {
    if (y.time_s < 10.0) {
      ASSERT_NEAR(y.tau_Nm, 20.0, 1e-12);
      ASSERT_EQ(y.limit_state, 0.0);
    }
  }
  // state 1 (power limited) from 10.8 s
  EXPECT_NEAR(first_time(ys, 0.0, [](const auto& y) { return y.limit_state == 1.0; }), 10.8, 0.05);
  // 10 kW held between ~14 and ~18 s with the torque decreasing
  const double t_10kW = first_time(ys, 10.0, [](const auto& y) { return y.power_mech_W > 9999.0; });
  EXPECT_NEAR(t_10kW, 14.0, 0.1);
  // state 2 (speed limit, torque cut) from ~18 s until ~38 s, when the falling request is
  // delivered again (the limiter stops cutting it)
  const double t_state2 = first_time(ys, 0.0, [](const auto& y) { return y.limit_state == 2.0; });
  EXPECT_NEAR(t_state2, 18.0, 0.5);
  const double t_met = first_time(ys, t_state2, [](const auto& y) { return y.limiting == 0.0; });
  EXPECT_NEAR(t_met, 38.0, 0.5);
  for (const auto& y : ys) {
    if (y.time_s > t_state2 && y.time_s < t_met) {
      ASSERT_EQ(y.limit_state, 2.0) << y.time_s;
    }
  }
  // after that the request is delivered to the end
  for (const auto& y : ys) {
    if (y.time_s > t_met) {
      ASSERT_NEAR(y.tau_Nm, y.tau_ref_Nm, 1e-12) << y.time_s;
    }
  }
  // constant-speed plateau: P_mech / P_el = 85.7 %
  const auto& plateau = ys[30000];
  ASSERT_NEAR(plateau.time_s, 30.0, 1e-9);
  EXPECT_NEAR(100.0 * plateau.power_mech_W / plateau.power_dc_W, 85.7, 0.1);
  // energy: DC energy in = losses + load work + kinetic energy change
  EXPECT_LE(std::abs(audit.residual_J), 1e-6 * audit.scale_J);
}

TEST(TestTwoFlange, SkipsThePowerLimitedStateAndBalancesPower) {
  const DriveRigParams params = load_rig("scenarios/two_flange_test.toml");
  const DriveRig rig(params);
  EnergyAudit audit;
  const auto ys = simulate(rig, 1e-3, 50.0, &audit);
  // w_max = 300 < P_max / tau_max = 366.7: the limiter goes 0 -> 2 directly (§1.3 quirk)
  for (const auto& y : ys) ASSERT_NE(y.limit_state, 1.0) << y.time_s;
  const double t2 = first_time(ys, 0.0, [](const auto& y) { return y.limit_state == 2.0; });
  EXPECT_GT(t2, 10.0);
  EXPECT_LT(t2, 30.0);
  for (const auto& y : ys) {
    // power through the flanges: A + B = tau w - J w dw/dt, A = -tau_A w
    ASSERT_NEAR(y.pow_del_a_W, 5.0 * y.speed_rad_s, 1e-9);
    ASSERT_NEAR(y.pow_del_a_W + y.pow_del_b_W, y.pow_del_W, 1e-9);
    ASSERT_NEAR(y.power_dc_W, y.power_mech_W, 1e-9);  // ideal drive
  }
  EXPECT_LE(std::abs(audit.residual_J), 1e-6 * audit.scale_J);
}

}  // namespace
}  // namespace ehpt::plant
