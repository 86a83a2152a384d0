// The map-based EV (MBEV, MODELS.md §10.3) on Sort1 and NEDC, break-away, stiction without
// chattering, slope, and the energy audit.
#include "plant/bev_plant.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "solvers/event_stepper.hpp"
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
    plant.outputs(stepper.time_s(n), x, m, {}, y);
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
    const solvers::StepReport r = stepper.advance(n, x, m, {});
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
  // v_ref = a t: stuck until k a t (G / r) = f m g, located inside the step
  BevParams p = test::mbev();
  const double a = 1.0;
  p.driver.cycle_m_s = Table1d({0.0, 10.0}, {0.0, 10.0 * a}, Extrapolation::kHold);
  const double f_roll = 0.014 * 1300.0 * kGravity_m_s2;
  const double t_break = f_roll / (p.driver.gain * a * p.body.gear_ratio / p.body.wheel_radius_m);
  const double h = 1e-3;
  const DriveSummary s = drive_cycle(p, h, 1.0);
  ASSERT_EQ(s.events, 1);
  EXPECT_NEAR(s.event_times_s[0], t_break, 1e-6 * h);
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

}  // namespace
}  // namespace ehpt::plant
