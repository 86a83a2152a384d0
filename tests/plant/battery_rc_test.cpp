// SPDX-License-Identifier: BSD-3-Clause
#include "plant/battery_rc.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "solvers/integrators.hpp"

namespace ehpt::plant {
namespace {

BatteryRcParams psd_battery() {
  // §6.3 example: the power-split battery of §10.4
  BatteryRcParams p;
  p.cell_capacity_Ah = 13.0;  // 46 800 As
  p.cell_emf_min_V = 0.9;
  p.cell_emf_max_V = 1.45;
  p.r0_cell_Ohm = 0.0003;
  p.cell_current_max_A = 1e5;
  p.cell_current_efficiency_A = 97.5;
  p.efficiency = 0.85;
  p.cells_series = 168;
  return p;
}

TEST(BatteryRc, DerivedConstantsMatchTheFactSheetExamples) {
  const BatteryRcConstants c = derive(psd_battery());
  EXPECT_NEAR(c.c_batt_F, 506.49, 0.01);
  EXPECT_NEAR(c.emf_min_V, 151.2, 1e-9);
  EXPECT_NEAR(c.emf_max_V, 243.6, 1e-9);
  EXPECT_NEAR(c.r0_Ohm, 0.0504, 1e-12);
  EXPECT_NEAR(c.r1_Ohm, 0.0504, 1e-12);
  EXPECT_NEAR(c.c1_F, 1190.48, 0.01);
  EXPECT_NEAR(c.k_parasitic, 0.03142, 1e-5);
  EXPECT_NEAR(c.efficiency_max, 0.9051, 1e-4);

  BatteryRcParams mbev;  // Batt1 defaults with ns 100, 100 Ah
  mbev.cell_capacity_Ah = 100.0;
  mbev.cells_series = 100;
  const BatteryRcConstants m = derive(mbev);
  EXPECT_NEAR(m.c_batt_F, 4235.29, 0.01);
  EXPECT_NEAR(m.r0_Ohm, 0.02075, 1e-12);
  EXPECT_NEAR(m.emf_min_V, 330.0, 1e-9);
  EXPECT_NEAR(m.emf_max_V, 415.0, 1e-9);
  EXPECT_NEAR(m.k_parasitic, 0.02549, 1e-5);
}

TEST(BatteryRc, ParasiticBranchGivesTheStatedRoundTripEfficiency) {
  // §6.3: energy ratio of a full swing at constant cell current I_eff with mean EMF and
  // lumped resistance, eta = (E - R I)(1 - k) / ((E + R I)(1 + k)), must be the user's value
  for (double eta : {0.7, 0.85, 0.9}) {
    BatteryRcParams p = psd_battery();
    p.efficiency = eta;
    const BatteryRcConstants c = derive(p);
    const double e_mean = 0.5 * (c.emf_min_V + c.emf_max_V);
    const double ri = (c.r0_Ohm + c.r1_Ohm) * 97.5;
    EXPECT_NEAR((e_mean - ri) * (1.0 - c.k_parasitic) / ((e_mean + ri) * (1.0 + c.k_parasitic)), eta, 1e-12);
  }
  // above eta_max the parasitic coefficient would be negative: rejected at load
  BatteryRcParams p = psd_battery();
  p.efficiency = 0.95;
  Problems problems;
  validate(p, "battery", problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems.list()[0].field, "battery.efficiency");
}

// A battery on an imposed constant current, for the closed-form checks.
struct ConstantCurrentBattery {
  static constexpr int kNumStates = 4;  // E, v_rc, terminal energy out, loss energy
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {};
  BatteryRc battery;
  double current_A;  // > 0 discharging
  void derivatives(double, const State& x, const Modes&, const Inputs&, State& dx) const {
    const BatteryTerminal b = battery.at_current(x[0], x[1], current_A);
    dx[0] = battery.demf_dt(b);
    dx[1] = battery.dvrc_dt(b, x[1]);
    dx[2] = b.voltage_V * b.current_A;
    dx[3] = b.loss_W;
  }
};

TEST(BatteryRc, ConstantCurrentDischargeMatchesClosedForm) {
  const BatteryRcParams params = psd_battery();
  const ConstantCurrentBattery plant{BatteryRc(params), 50.0};
  const BatteryRcConstants& c = plant.battery.constants();
  solvers::Rk4<ConstantCurrentBattery> rk4(plant);
  ConstantCurrentBattery::State x;
  x << c.emf_initial_V, 0.0, 0.0, 0.0;
  const double e0 = x[0];
  const double h = 0.01;
  const int n = 60000;  // 600 s, ten RC time constants
  for (int i = 0; i < n; ++i) rk4.step(i * h, h, {}, {}, x);
  const double t = n * h;
  const double i_m = 50.0 * (1.0 + c.k_parasitic);
  const double tau = c.r1_Ohm * c.c1_F;  // 60 s
  EXPECT_NEAR(x[0], e0 - i_m * t / c.c_batt_F, 1e-9);
  EXPECT_NEAR(x[1], c.r1_Ohm * i_m * (1.0 - std::exp(-t / tau)), 1e-9);
  const double v_term = x[0] - x[1] - c.r0_Ohm * 50.0;
  EXPECT_NEAR(plant.battery.at_current(x[0], x[1], 50.0).voltage_V, v_term, 1e-12);
  // energy: decrease of the stored energy = energy out + losses
  const double stored_out = plant.battery.stored_energy_J(e0, 0.0) - plant.battery.stored_energy_J(x[0], x[1]);
  EXPECT_NEAR(stored_out, x[2] + x[3], 1e-6 * stored_out);
}

TEST(BatteryRc, AFullSwingAtTheEfficiencyCurrentGivesTheStatedRoundTripEfficiency) {
  // discharge SOC 1 -> 0 and charge 0 -> 1 at the cell current I_eff; the energy ratio is the
  // stated efficiency up to the RC block's transients (the derivation of k assumes v_rc at
  // steady state); without the parasitic branch it would be eta_max = 0.905
  for (double eta : {0.80, 0.85}) {
    BatteryRcParams params = psd_battery();
    params.efficiency = eta;
    params.soc_initial = 1.0;
    const BatteryRc battery(params);
    const BatteryRcConstants& c = battery.constants();
    ConstantCurrentBattery plant{battery, 97.5};
    ConstantCurrentBattery::State x;
    x << c.emf_max_V, 0.0, 0.0, 0.0;
    const double h = 0.01;
    int n = 0;
    for (solvers::Rk4<ConstantCurrentBattery> rk4(plant); battery.soc(x[0]) > 0.0; ++n) rk4.step(n * h, h, {}, {}, x);
    const double energy_out_J = x[2];
    plant.current_A = -97.5;
    x[2] = 0.0;
    for (solvers::Rk4<ConstantCurrentBattery> rk4(plant); battery.soc(x[0]) < 1.0; ++n) rk4.step(n * h, h, {}, {}, x);
    const double energy_in_J = -x[2];
    // the RC block starts each half-swing relaxed, so it loses a little less than assumed
    EXPECT_GT(energy_out_J / energy_in_J, eta);
    EXPECT_LT(energy_out_J / energy_in_J, eta + 0.01);
  }
}

TEST(BatteryRc, ParallelStringsScaleThePackNotTheCell) {
  BatteryRcParams one = psd_battery(), two = psd_battery();
  two.strings_parallel = 2;
  const BatteryRcConstants a = derive(one), b = derive(two);
  EXPECT_NEAR(b.c_batt_F, 2.0 * a.c_batt_F, 1e-9);
  EXPECT_NEAR(b.r0_Ohm, 0.5 * a.r0_Ohm, 1e-15);
  EXPECT_NEAR(b.c1_F, 2.0 * a.c1_F, 1e-9);
  EXPECT_NEAR(b.current_max_A, 2.0 * a.current_max_A, 1e-9);
  EXPECT_EQ(b.emf_max_V, a.emf_max_V);
  EXPECT_EQ(b.k_parasitic, a.k_parasitic);  // cell values: the same efficiency per cell (§6.3)
}

TEST(BatteryRc, ConstantPowerLoadSolvesTheNodeAndFlagsInfeasiblePower) {
  const BatteryRc b(psd_battery());
  const double e = 200.0, vrc = 1.0;
  const BatteryTerminal t = b.terminal(e, vrc, 20000.0);
  EXPECT_TRUE(t.feasible);
  EXPECT_NEAR(t.voltage_V * t.current_A, 20000.0, 1e-6);
  EXPECT_NEAR(t.voltage_V, e - vrc - b.constants().r0_Ohm * t.current_A, 1e-9);
  const double p_max = (e - vrc) * (e - vrc) / (4.0 * b.constants().r0_Ohm);
  EXPECT_FALSE(b.terminal(e, vrc, 1.01 * p_max).feasible);
  // charging: negative power, current < 0, voltage above the internal EMF
  const BatteryTerminal ch = b.terminal(e, vrc, -20000.0);
  EXPECT_LT(ch.current_A, 0.0);
  EXPECT_GT(ch.voltage_V, e - vrc);
}

TEST(BatteryRc, ValidateCollectsEveryProblem) {
  BatteryRcParams p;
  p.cell_capacity_Ah = -1.0;
  p.soc_initial = 1.5;
  p.cells_series = 0;
  Problems problems;
  validate(p, "battery", problems);
  EXPECT_EQ(problems.size(), 3u);
}

}  // namespace
}  // namespace ehpt::plant
