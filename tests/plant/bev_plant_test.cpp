// SPDX-License-Identifier: BSD-3-Clause
// The map-based EV (MBEV, MODELS.md §10.3) on Sort1 and NEDC, break-away, stiction without
// chattering, slope, and the energy audit.
#include "plant/bev_plant.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "hil/config/config.hpp"
#include "solvers/event_stepper.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

struct DriveSummary {
  double distance_m = 0.0;
  double rms_kmh = 0.0, max_kmh = 0.0;
  double max_kmh_urban = 0.0;  // t < 780 s on NEDC (ECE-15 part, <= 50 km/h)
  int events = 0;
  int chattering = 0;
  int standstills = 0, standstills_locked = 0;
  std::vector<double> event_times_s;
  EnergyAudit audit;
};

template <class Integrator = solvers::Rk4<BevPlant>>
DriveSummary drive_cycle(const BevParams& params, double h_s, double duration_s) {
  const BevPlant plant(params);
  Integrator integrator(plant);
  solvers::EventStepper<BevPlant, Integrator> stepper(plant, integrator, 0.0, h_s);
  BevPlant::State x = plant.initial_state();
  const BevPlant::State x0 = x;
  BevPlant::Modes m = plant.initial_modes(x);
  ecu::EvFollower follower;  // the built-in ECU, every step
  BevPlant::Inputs command;
  DriveSummary s;
  double sq = 0.0;
  const auto steps = std::llround(duration_s / h_s);
  // standstills of the cycle: rows with zero speed lasting at least 2 s; check the lock 0.5 s
  // before each ends (the vehicle has had time to stop)
  const Table1d& cyc = params.driver.cycle_m_s;
  std::vector<double> checks;
  for (std::size_t i = 0; i + 1 < cyc.x().size(); ++i) {
    if (cyc.y()[i] == 0.0 && cyc.y()[i + 1] == 0.0 && cyc.x()[i + 1] - cyc.x()[i] >= 2.0 && cyc.x()[i] > 0.0 &&
        cyc.x()[i + 1] <= duration_s) {
      checks.push_back(cyc.x()[i + 1] - 0.5);
    }
  }
  std::size_t next_check = 0;
  for (std::int64_t n = 0; n <= steps; ++n) {
    BevPlant::Outputs y;
    plant.outputs(stepper.time_s(n), x, m, command, y);
    const double e = 3.6 * (y.speed_ref_m_s - y.speed_m_s);
    sq += e * e;
    s.max_kmh = std::max(s.max_kmh, std::abs(e));
    if (y.time_s < 780.0) s.max_kmh_urban = std::max(s.max_kmh_urban, std::abs(e));
    while (next_check < checks.size() && std::abs(y.time_s - checks[next_check]) < 0.5 * h_s) {
      ++s.standstills;
      s.standstills_locked += y.locked == 1.0 ? 1 : 0;
      ++next_check;
    }
    if (n == steps) break;
    const solvers::StepReport r = test::step_with_ecu(plant, stepper, follower, n, x, m, command);
    s.events += r.events;
    s.chattering += r.chattering ? 1 : 0;
    if (r.events > 0) s.event_times_s.push_back(r.event_time_s);
  }
  s.rms_kmh = std::sqrt(sq / static_cast<double>(steps + 1));
  s.distance_m = x[BevPlant::kDistance];
  s.audit = plant.audit(x0, x);
  return s;
}

// Stated tracking limits for the shipped MBEV (driver gain 1000 N m/(m/s), 22 kW drive):
// a proportional driver lags by (needed force) / (k G / r), i.e. < 1 km/h wherever the drive
// can deliver what is asked; on NEDC's extra-urban part (100 -> 120 km/h) the 22 kW drive is
// power-limited and falls behind by up to ~7 km/h (it needs 23-31 kW there).
TEST(BevOnSort1, FollowsTheCycleTravels052kmAndLocksAtEveryStop) {
  const DriveSummary s = drive_cycle(test::mbev("data/cycles/cycle_sort1.csv"), 1e-3, 150.0);
  EXPECT_NEAR(s.distance_m, 520.0, 5.2);  // 0.52 km +- 1 %
  EXPECT_LT(s.rms_kmh, 0.5);
  EXPECT_LT(s.max_kmh, 1.0);
  // three trapezoids: three starts (break-away) and three stops, nothing else
  EXPECT_EQ(s.events, 6);
  EXPECT_EQ(s.chattering, 0);
  EXPECT_EQ(s.standstills, 3);
  EXPECT_EQ(s.standstills_locked, 3);
  EXPECT_LE(std::abs(s.audit.residual_J), 1e-6 * s.audit.scale_J);
}

TEST(BevOnNedc, FollowsTheCycleWithinStatedLimitsAndClosesTheEnergyBalance) {
  const DriveSummary s = drive_cycle(test::mbev("data/cycles/cycle_nedc.csv"), 1e-3, 1184.0);
  EXPECT_NEAR(s.distance_m, 10983.0, 0.01 * 10983.0);
  EXPECT_LT(s.rms_kmh, 1.0);
  EXPECT_LT(s.max_kmh_urban, 1.0);
  EXPECT_LT(s.max_kmh, 8.0);
  EXPECT_EQ(s.chattering, 0);
  EXPECT_GE(s.standstills, 12);
  EXPECT_EQ(s.standstills_locked, s.standstills);
  EXPECT_LE(std::abs(s.audit.residual_J), 1e-6 * s.audit.scale_J);
}

TEST(BevOnSort1, ImplicitEulerAgreesWithRk4) {
  const BevParams p = test::mbev("data/cycles/cycle_sort1.csv");
  const DriveSummary rk4 = drive_cycle(p, 1e-3, 150.0);
  const DriveSummary ie = drive_cycle<solvers::ImplicitEuler<BevPlant>>(p, 1e-3, 150.0);
  EXPECT_NEAR(ie.distance_m, rk4.distance_m, 0.002 * rk4.distance_m);
  EXPECT_EQ(ie.events, rk4.events);
  // first order: the balance closes to O(h), not to round-off
  EXPECT_LE(std::abs(ie.audit.residual_J), 1e-3 * ie.audit.scale_J);
}

TEST(BevBreakAway, StartsWhenTheDriveForceExceedsRollingResistance) {
  // v_ref = a t: the driver's request k a t crosses f m g (r / G) at t_break; the ECU samples
  // it every step and its command acts from the sample on, so the car starts at the first
  // grid point at or after t_break, exactly there (a crossing below zero at a segment start)
  BevParams p = test::mbev();
  const double a = 1.0;
  p.driver.cycle_m_s = Table1d({0.0, 10.0}, {0.0, 10.0 * a}, Extrapolation::kHold);
  const double f_roll = 0.014 * 1300.0 * kGravity_m_s2;
  const double t_break = f_roll / (p.driver.gain * a * p.body.gear_ratio / p.body.wheel_radius_m);
  const double h = 1e-3;
  const DriveSummary s = drive_cycle(p, h, 1.0);
  ASSERT_EQ(s.events, 1);
  EXPECT_NEAR(s.event_times_s[0], std::ceil(t_break / h) * h, 1e-12);
  EXPECT_GT(s.event_times_s[0], t_break - 1e-12);
  EXPECT_LT(s.event_times_s[0], t_break + h);
}

TEST(BevStiction, HeldBelowBreakAwayWithoutChattering) {
  // the driver pushes with 90 % of the break-away force for 20 s: the car must not move
  BevParams p = test::mbev();
  const double f_roll = 0.014 * 1300.0 * kGravity_m_s2;
  const double v_hold = 0.9 * f_roll / (p.driver.gain * p.body.gear_ratio / p.body.wheel_radius_m);
  p.driver.cycle_m_s = Table1d({0.0, 20.0}, {v_hold, v_hold}, Extrapolation::kHold);
  const DriveSummary s = drive_cycle(p, 1e-3, 20.0);
  EXPECT_EQ(s.events, 0);
  EXPECT_EQ(s.distance_m, 0.0);
}

TEST(BevOnSlope, ClimbsAndDescendsTheAngle1RoadAndBalancesPotentialEnergy) {
  BevParams p = test::mbev("data/cycles/cycle_test_angle.csv");
  const Table1d slope({0, 100, 110, 200, 220, 300, 310, 1000}, {0, 0, 0.1, 0.1, -0.1, -0.1, 0, 0},
                      Extrapolation::kHold);
  p.road.slope_rad = slope;
  const DriveSummary s = drive_cycle(p, 1e-3, 200.0);
  EXPECT_GT(s.distance_m, 450.0);
  EXPECT_LE(std::abs(s.audit.residual_J), 1e-6 * s.audit.scale_J);
  // potential energy term = m g * integral of sin(alpha) ds over the whole road
  double rise_m = 0.0;
  for (double x = 0.0; x < s.distance_m; x += 1e-3) rise_m += 1e-3 * std::sin(slope(x + 0.5e-3));
  double potential = 0.0;
  for (const auto& [name, value] : s.audit.terms) {
    if (name == "potential_energy_change_J") potential = value;
  }
  EXPECT_NEAR(potential, 1300.0 * kGravity_m_s2 * rise_m, 1e-3 * 1300.0 * kGravity_m_s2);
}

// The library tutorial's figures for MBEV (MODELS.md §10.3 and its 2026-11-22 corrections):
// with the library's set-up (driver k = 100, MBEV's brake: gain G*r and its torque signal
// after the rotor inertia, NEDC repeated to 1400 s) the tutorial reports 116 Wh/km on NEDC
// and 133 Wh/km on WLTC3 as EMF-side energy per km, (enBatDel + enBattLoss) / distance; an
// independent re-simulation of the library's equations gives 115.84 and 133.32, terminal
// energy about 111.5 and 128.3. The brake's signal matters at the 0.2 % level (115.62 without).
TEST(TutorialFigures, MapBasedEvWhPerKmOnNedcAndWltc3) {
  struct Case {
    const char* scenario;
    double published, resimulated, terminal;
  };
  for (const Case& c : {Case{"scenarios/ev_tutorial_nedc.toml", 116.0, 115.84, 111.5},
                        Case{"scenarios/ev_tutorial_wltc3.toml", 133.0, 133.32, 128.3}}) {
    const hil::Scenario sc = test::load(test::source_path(c.scenario));
    const BevParams& p = sc.plant.get<BevParams>();
    ASSERT_TRUE(p.brake.after_rotor_inertia && p.brake.library_gain) << c.scenario;
    ASSERT_EQ(p.driver.gain, 100.0);
    const DriveSummary s = drive_cycle(p, 1e-3, sc.solver.duration_s);
    const double km = s.distance_m / 1000.0;
    const double emf_Wh_km = (s.audit.battery_out_J + s.audit.battery_loss_J) / 3600.0 / km;
    const double terminal_Wh_km = s.audit.battery_out_J / 3600.0 / km;
    EXPECT_NEAR(emf_Wh_km, c.published, 0.005 * c.published) << c.scenario;       // ehpt 115.85 / 133.33
    EXPECT_NEAR(emf_Wh_km, c.resimulated, 0.0005 * c.resimulated) << c.scenario;  // 0.05 %
    EXPECT_NEAR(terminal_Wh_km, c.terminal, 0.005 * c.terminal) << c.scenario;    // ehpt 111.49 / 128.31
    EXPECT_LE(std::abs(s.audit.residual_J), 1e-6 * s.audit.scale_J) << c.scenario;
  }
}

// MBEV's brake signal tau - J dw/dt - tau_req is an algebraic loop (dw/dt depends on the brake
// force): the solved force satisfies it at every point, and it brakes a little in every
// deceleration even where the drive is not at its limit.
TEST(BevBrake, AfterRotorInertiaSolvesItsLoopExactly) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/ev_tutorial_nedc.toml"));
  const BevParams& p = sc.plant.get<BevParams>();
  const BevPlant plant(p);
  solvers::Rk4<BevPlant> rk4(plant);
  solvers::EventStepper<BevPlant, solvers::Rk4<BevPlant>> stepper(plant, rk4, 0.0, 1e-3);
  BevPlant::State x = plant.initial_state();
  BevPlant::Modes m = plant.initial_modes(x);
  ecu::EvFollower follower;
  BevPlant::Inputs command;
  const double g_over_r = p.body.gear_ratio / p.body.wheel_radius_m;
  const double k = brake_gain_N_per_Nm(p.brake, p.body);
  int braking_unlimited = 0, checked = 0;
  double seen_t = -1.0;
  BevPlant::State seen_x = x;
  BevPlant::Inputs seen_command;
  for (std::int64_t n = 0; n < 1200000; ++n) {
    if (n % 100 == 0 && m.motion == Motion::kForward) {
      BevPlant::Outputs y;
      plant.outputs(stepper.time_s(n), x, m, command, y);
      const double signal_Nm = y.drive_torque_Nm - p.drive.inertia_kgm2 * g_over_r * y.acceleration_m_s2 -
                               y.drive_torque_ref_Nm;
      ASSERT_NEAR(y.brake_force_N, k * std::max(0.0, signal_Nm), 1e-9 * (1.0 + y.brake_force_N)) << y.time_s;
      if (y.brake_force_N > 0.0 && y.drive_limiting == 0.0) {
        ++braking_unlimited;
        seen_t = y.time_s;
        seen_x = x;
        seen_command = command;
      }
      ++checked;
    }
    test::step_with_ecu(plant, stepper, follower, n, x, m, command);
  }
  EXPECT_GT(checked, 5000);
  EXPECT_GT(braking_unlimited, 100);
  // with the applied torque (the default) the same point has no braking at all
  ASSERT_GE(seen_t, 0.0);
  BevParams q = p;
  q.brake.after_rotor_inertia = false;
  BevPlant::Outputs y;
  BevPlant(q).outputs(seen_t, seen_x, {Motion::kForward}, seen_command, y);
  EXPECT_EQ(y.drive_limiting, 0.0);
  EXPECT_EQ(y.brake_force_N, 0.0);
}

}  // namespace
}  // namespace ehpt::plant
