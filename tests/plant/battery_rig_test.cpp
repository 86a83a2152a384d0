// SPDX-License-Identifier: BSD-3-Clause
// Battery test rig: Batt1 (MODELS.md §6) on constant-current / constant-power segments.
#include "plant/battery_rig.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "solvers/event_stepper.hpp"

namespace ehpt::plant {
namespace {

using Kind = BatterySegment::Kind;

// MBEV's battery (§10.3): Batt1 defaults with ns 100, 100 Ah cells, SOC 0.7.
BatteryRcParams mbev_battery() {
  BatteryRcParams p;
  p.cell_capacity_Ah = 100.0;
  p.cells_series = 100;
  p.soc_initial = 0.7;
  return p;
}

// One default 10 Ah cell with a short RC time constant (R1 C1 = 2 s), so the transient shows.
BatteryRcParams small_battery() {
  BatteryRcParams p;
  p.r1_cell_Ohm = 0.004;
  p.c1_cell_F = 500.0;
  p.soc_initial = 0.9;
  return p;
}

struct RigRun {
  std::vector<BatteryRig::Outputs> ys;  // every `every`-th step, and the last one
  BatteryRig::State x0, x;
};

// RK4 through the event stepper on the grid n h, as the runner does.
RigRun simulate(const BatteryRig& rig, double h_s, double duration_s, std::int64_t every = 1) {
  solvers::Rk4<BatteryRig> rk4(rig);
  solvers::EventStepper<BatteryRig, solvers::Rk4<BatteryRig>> stepper(rig, rk4, 0.0, h_s);
  RigRun r;
  BatteryRig::State x = rig.initial_state();
  r.x0 = x;
  BatteryRig::Modes m = rig.initial_modes(x);
  const auto steps = std::llround(duration_s / h_s);
  for (std::int64_t n = 0; n <= steps; ++n) {
    if (n % every == 0 || n == steps) {
      BatteryRig::Outputs y;
      rig.outputs(stepper.time_s(n), x, m, {}, y);
      r.ys.push_back(y);
    }
    if (n < steps) stepper.advance(n, x, m, {});
  }
  r.x = x;
  return r;
}

// The output sampled at time t_s (exactly on the grid of the run).
const BatteryRig::Outputs& at(const RigRun& r, double t_s) {
  for (const auto& y : r.ys) {
    if (std::abs(y.time_s - t_s) < 1e-9) return y;
  }
  ADD_FAILURE() << "no sample at t = " << t_s;
  return r.ys.front();
}

TEST(BatteryRig, ConstantCurrentDischargeMatchesTheClosedForm) {
  struct Case {
    BatteryRcParams battery;
    double current_A, duration_s;
  };
  for (const Case& c : {Case{mbev_battery(), 200.0, 300.0}, Case{small_battery(), 20.0, 30.0}}) {
    // the segment outlasts the run: at its end time the rig would rest (right-continuous)
    const BatteryRig rig({c.battery, {{Kind::kCurrent, c.current_A, c.duration_s + 1.0}}});
    const BatteryRcConstants& k = rig.battery().constants();
    const double h = 1e-3;
    const RigRun r = simulate(rig, h, c.duration_s, 1000);  // a sample every second, t = T included
    const double e0 = k.emf_initial_V;
    const double i_m = c.current_A * (1.0 + k.k_parasitic);
    const double tau_s = k.r1_Ohm * k.c1_F;
    ASSERT_EQ(r.ys.size(), static_cast<std::size_t>(std::llround(c.duration_s)) + 1);
    for (const auto& y : r.ys) {
      const double t = y.time_s;
      const double e = e0 - i_m * t / k.c_batt_F;
      const double v_rc = k.r1_Ohm * i_m * (1.0 - std::exp(-t / tau_s));
      const double v_term = e - v_rc - k.r0_Ohm * c.current_A;
      const double soc = (e - k.emf_min_V) / (k.emf_max_V - k.emf_min_V);
      ASSERT_EQ(y.profile_segment, 0.0) << t;
      ASSERT_EQ(y.current_ref_A, c.current_A) << t;
      ASSERT_EQ(y.battery_current_A, c.current_A) << t;
      // E has a constant derivative, so RK4 is exact and only rounding remains: n steps of a
      // constant increment to a 400 V number drift by ~1e-9 V after 40 000 steps (seen: 2e-11
      // relative), hence relative bounds for E and v_term
      ASSERT_NEAR(y.battery_emf_V, e, 1e-9 * e) << t;
      ASSERT_NEAR(y.battery_vrc_V, v_rc, 1e-9) << t;
      ASSERT_NEAR(y.battery_voltage_V, v_term, 1e-9 * v_term) << t;
      ASSERT_NEAR(y.soc, soc, 1e-9) << t;
      ASSERT_NEAR(y.charge_out_As, c.current_A * t, 1e-9 * c.current_A * c.duration_s) << t;
      ASSERT_EQ(y.fault, 0.0) << t;
    }
    // the run really moved: SOC dropped, the RC block charged
    EXPECT_LT(r.ys.back().soc, c.battery.soc_initial - 0.01);
    EXPECT_GT(r.ys.back().battery_vrc_V, 0.1 * k.r1_Ohm * i_m);
  }
}

TEST(BatteryRig, ConstantPowerSegmentDeliversThePower) {
  const double p_dis_W = 50e3, p_ch_W = -30e3;
  const BatteryRig rig({mbev_battery(), {{Kind::kPower, p_dis_W, 120.0}, {Kind::kPower, p_ch_W, 60.0}}});
  const RigRun r = simulate(rig, 1e-3, 180.0, 500);
  int seen = 0;
  for (const auto& y : r.ys) {
    const double t = y.time_s;
    // [0, 120) s discharge, from 120 s the charge segment; at 180 s the rig rests
    if (t >= 180.0) continue;
    const double p = t < 120.0 ? p_dis_W : p_ch_W;
    ASSERT_EQ(y.profile_segment, t < 120.0 ? 0.0 : 1.0) << t;
    ASSERT_EQ(y.power_ref_W, p) << t;
    ASSERT_EQ(y.current_ref_A, 0.0) << t;
    ASSERT_NEAR(y.battery_power_W, p, 1e-9 * std::abs(p)) << t;
    ASSERT_NEAR(y.battery_voltage_V * y.battery_current_A, p, 1e-9 * std::abs(p)) << t;
    // the node: v_term = E - v_rc - R0 i with i = P / v_term
    ASSERT_NEAR(y.battery_voltage_V,
                y.battery_emf_V - y.battery_vrc_V - rig.battery().constants().r0_Ohm * y.battery_current_A,
                1e-9 * y.battery_voltage_V)
        << t;
    ASSERT_EQ(y.fault, 0.0) << t;
    // the terminal energy grows as P t during the first segment (constant derivative)
    if (t < 120.0) {
      ASSERT_NEAR(y.battery_out_J, p_dis_W * t, 1e-9 * p_dis_W * 120.0) << t;
      ++seen;
    }
  }
  EXPECT_EQ(seen, 240);
  // charging (the last sample before the end): negative current, voltage above E - v_rc
  const auto& charging = r.ys[r.ys.size() - 2];
  EXPECT_EQ(charging.time_s, 179.5);
  EXPECT_LT(charging.battery_current_A, 0.0);
  EXPECT_GT(charging.battery_voltage_V, charging.battery_emf_V - charging.battery_vrc_V);
}

TEST(BatteryRig, ChargeRaisesSocSegmentsSwitchOnTimeAndTheRigRestsAfterTheProfile) {
  const double h = 1e-3;
  const BatteryRig rig({small_battery(), {{Kind::kCurrent, 10.0, 6.0}, {Kind::kCurrent, -20.0, 4.0}}});
  EXPECT_EQ(rig.profile_end_s(), 10.0);
  const RigRun r = simulate(rig, h, 14.0);
  // the boundary at 6 s is an event: the segment that ends there runs up to it, the next
  // one applies from it (right-continuous)
  EXPECT_EQ(at(r, 6.0 - h).profile_segment, 0.0);
  EXPECT_EQ(at(r, 6.0 - h).current_ref_A, 10.0);
  EXPECT_EQ(at(r, 6.0).profile_segment, 1.0);
  EXPECT_EQ(at(r, 6.0).battery_current_A, -20.0);
  EXPECT_EQ(at(r, 6.0 + h).profile_segment, 1.0);
  EXPECT_EQ(at(r, 6.0 + h).current_ref_A, -20.0);
  // the charge at 6 s is exactly 10 A x 6 s: no step mixed the two segments
  EXPECT_NEAR(at(r, 6.0).charge_out_As, 60.0, 1e-9);
  EXPECT_NEAR(at(r, 10.0).charge_out_As, 60.0 - 80.0, 1e-9);
  // discharge lowers SOC, the charge segment raises it above where it started
  EXPECT_LT(at(r, 6.0).soc, at(r, 0.0).soc);
  for (double t = 6.0 + h; t < 9.5; t += 0.5) EXPECT_GT(at(r, t + 0.5).soc, at(r, t).soc) << t;
  EXPECT_GT(at(r, 10.0).soc, at(r, 0.0).soc);  // 20 A x 4 s (1 - k) > 10 A x 6 s (1 + k)
  // rest after the profile: -1, no current, E frozen, the RC block relaxes towards 0
  EXPECT_EQ(at(r, 10.0 - h).profile_segment, 1.0);
  const auto& rest0 = at(r, 10.0);
  EXPECT_EQ(rest0.profile_segment, -1.0);
  EXPECT_EQ(rest0.current_ref_A, 0.0);
  EXPECT_EQ(rest0.power_ref_W, 0.0);
  EXPECT_EQ(rest0.battery_current_A, 0.0);
  const auto& rest1 = at(r, 14.0);
  EXPECT_EQ(rest1.profile_segment, -1.0);
  EXPECT_EQ(rest1.battery_emf_V, rest0.battery_emf_V);
  EXPECT_LT(rest0.battery_vrc_V, 0.0);  // charged last
  EXPECT_NEAR(rest1.battery_vrc_V, rest0.battery_vrc_V * std::exp(-4.0 / 2.0), 1e-12);
  EXPECT_EQ(rest1.charge_out_As, rest0.charge_out_As);
  EXPECT_EQ(rest1.battery_voltage_V, rest1.battery_emf_V - rest1.battery_vrc_V);
}

TEST(BatteryRig, EnergyAuditBalancesOverAMixedProfile) {
  const BatteryRig rig({mbev_battery(),
                        {{Kind::kCurrent, 300.0, 120.0},
                         {Kind::kPower, 80e3, 60.0},
                         {Kind::kCurrent, -200.0, 90.0},
                         {Kind::kPower, -40e3, 45.0},
                         {Kind::kCurrent, 50.0, 30.0}}});
  const RigRun r = simulate(rig, 1e-3, 400.0, 1000);  // 55 s of rest at the end
  const EnergyAudit a = rig.audit(r.x0, r.x);
  ASSERT_GT(a.scale_J, 1e6);
  // seen: 3.5e-10 at h = 1 ms, set by rounding of E (C_batt E dE), not by the segment jumps:
  // it grows as h shrinks (1.0e-10 at 4 ms, 1.1e-9 at 0.5 ms)
  EXPECT_LE(std::abs(a.residual_J), 1e-9 * a.scale_J) << a.residual_J << " of " << a.scale_J;
  EXPECT_EQ(a.battery_out_J, r.x[BatteryRig::kBatteryOutJ]);
  ASSERT_EQ(a.terms.size(), 3u);
  EXPECT_EQ(a.terms[0].first, "battery_stored_out_J");
  EXPECT_EQ(a.terms[1].first, "battery_terminal_out_J");
  EXPECT_EQ(a.terms[2].first, "battery_losses_J");
  EXPECT_EQ(a.sources_J, a.terms[0].second);
  EXPECT_GT(a.terms[2].second, 0.0);
  for (const auto& y : r.ys) ASSERT_EQ(y.fault, 0.0) << y.time_s;
}

TEST(BatteryRig, FaultBitsFollowTheBatteryAndTheState) {
  const BatteryRig rig({mbev_battery(), {{Kind::kPower, 1e7, 1.0}, {Kind::kCurrent, 5000.0, 1.0}}});
  BatteryRig::State x = rig.initial_state();
  BatteryRig::Outputs y;
  rig.outputs(0.5, x, {0}, {}, y);  // 10 MW: beyond the pack's maximum power
  EXPECT_EQ(static_cast<unsigned>(y.fault) & kFaultPowerInfeasible, kFaultPowerInfeasible);
  rig.outputs(1.5, x, {1}, {}, y);  // 5000 A: 50 C
  EXPECT_EQ(static_cast<unsigned>(y.fault), kFaultCellCurrent);
  x[BatteryRig::kVrc] = std::numeric_limits<double>::quiet_NaN();
  rig.outputs(3.0, x, {BatteryRig::kRest}, {}, y);
  EXPECT_EQ(static_cast<unsigned>(y.fault), kFaultNonFinite);
}

TEST(BatteryRig, ValidateNamesEveryBadField) {
  BatteryRigParams p{mbev_battery(), {}};
  Problems empty;
  validate(p, empty);
  ASSERT_EQ(empty.size(), 1u);
  EXPECT_EQ(empty.list()[0].field, "profile");

  const double nan = std::numeric_limits<double>::quiet_NaN();
  p.profile = {{Kind::kCurrent, 10.0, 1.0},
               {Kind::kCurrent, 10.0, 0.0},
               {Kind::kPower, 1e3, nan},
               {Kind::kPower, nan, 2.0},
               {Kind::kCurrent, -5.0, -1.0}};
  Problems problems;
  validate(p, problems);
  ASSERT_EQ(problems.size(), 4u);
  EXPECT_EQ(problems.list()[0].field, "profile[1].duration_s");
  EXPECT_EQ(problems.list()[0].value, "0");
  EXPECT_EQ(problems.list()[1].field, "profile[2].duration_s");
  EXPECT_EQ(problems.list()[1].value, "nan");
  EXPECT_EQ(problems.list()[2].field, "profile[3].power_W");  // the key the user wrote
  EXPECT_EQ(problems.list()[2].value, "nan");
  EXPECT_EQ(problems.list()[3].field, "profile[4].duration_s");
  EXPECT_EQ(problems.list()[3].value, "-1");

  // the battery is validated under "battery"
  p.profile = {{Kind::kCurrent, 10.0, 1.0}};
  p.battery.cell_capacity_Ah = -1.0;
  Problems bad_battery;
  validate(p, bad_battery);
  ASSERT_EQ(bad_battery.size(), 1u);
  EXPECT_EQ(bad_battery.list()[0].field, "battery.cell_capacity_Ah");
}

TEST(BatteryRig, SignalsNameEveryOutputOnce) {
  const auto& s = BatteryRig::kSignals;
  EXPECT_EQ(s.front().name, "time_s");
  EXPECT_EQ(s.back().name, "fault");
  for (std::size_t i = 0; i < s.size(); ++i) {
    for (std::size_t j = i + 1; j < s.size(); ++j) {
      EXPECT_NE(s[i].name, s[j].name);
      EXPECT_NE(s[i].member, s[j].member);
    }
  }
}

// A grid time that rounds a hair below a segment's end still ends the segment on that step:
// the profile ends at 1.0 + 0.281 = 1.2810000000000001 s, the grid's last point is
// 1281 * 0.001 = 1.281 s, 2e-16 s before it.
TEST(BatteryRig, ASegmentEndOnTheGridSwitchesOnThatStepWhateverTheRounding) {
  const BatteryRig rig({small_battery(), {{Kind::kCurrent, 10.0, 1.0}, {Kind::kCurrent, 20.0, 0.281}}});
  ASSERT_LT(1281 * 1e-3, rig.profile_end_s());
  const RigRun r = simulate(rig, 1e-3, 1.281);
  EXPECT_EQ(at(r, 1.0).profile_segment, 1.0);
  EXPECT_EQ(r.ys.back().profile_segment, -1.0);  // the end of the profile is rest, at the last row
  EXPECT_NEAR(r.ys.back().charge_out_As, 10.0 * 1.0 + 20.0 * 0.281, 1e-9);
}

}  // namespace
}  // namespace ehpt::plant
