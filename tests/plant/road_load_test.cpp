// SPDX-License-Identifier: BSD-3-Clause
// Coast-down from 100 km/h under road load only, against the closed-form solutions, in both
// road-load forms; stop located inside the step; stuck afterwards with no further events.
#include "plant/road_load.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "plant/bev_plant.hpp"
#include "solvers/event_stepper.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

// A vehicle whose driver asks for (practically) nothing and whose drive has no inertia:
// only the road load acts.
BevParams coasting_vehicle(const RoadLoadParams& road, double v0_m_s) {
  BevParams p = test::mbev();
  p.road = road;
  p.driver.cycle_m_s = Table1d({0.0, 1000.0}, {0.0, 0.0}, Extrapolation::kHold);
  p.driver.gain = 1e-300;
  p.drive.inertia_kgm2 = 1e-300;
  p.body.speed_initial_m_s = v0_m_s;
  return p;
}

struct CoastResult {
  double speed_at_10s_m_s = 0.0;
  double stop_time_s = -1.0;
  int events = 0;
  bool locked_at_end = false;
};

CoastResult coast(const BevParams& params, double h_s, double duration_s) {
  const BevPlant plant(params);
  solvers::Rk4<BevPlant> rk4(plant);
  solvers::EventStepper<BevPlant, solvers::Rk4<BevPlant>> stepper(plant, rk4, 0.0, h_s);
  BevPlant::State x = plant.initial_state();
  BevPlant::Modes m = plant.initial_modes(x);
  CoastResult r;
  const auto n_end = static_cast<std::int64_t>(std::llround(duration_s / h_s));
  for (std::int64_t n = 0; n < n_end; ++n) {
    const solvers::StepReport s = stepper.advance(n, x, m, {});
    r.events += s.events;
    if (s.events > 0 && r.stop_time_s < 0.0) r.stop_time_s = s.event_time_s;
    if (n + 1 == std::llround(10.0 / h_s)) r.speed_at_10s_m_s = x[BevPlant::kSpeed];
  }
  r.locked_at_end = m.motion == Motion::kStuck && x[BevPlant::kSpeed] == 0.0;
  return r;
}

TEST(CoastDown, CoefficientsFormMatchesClosedForm) {
  RoadLoadParams road;
  road.rolling_coefficient = 0.014;
  road.air_density_kg_m3 = 1.226;
  road.frontal_area_m2 = 2.2;
  road.drag_coefficient = 0.26;
  const double m = 1300.0, v0 = 100.0 / 3.6, h = 1e-3;
  const double a = 0.014 * m * kGravity_m_s2, b = 0.5 * 1.226 * 2.2 * 0.26;
  const double phi0 = std::atan(v0 * std::sqrt(b / a)), rate = std::sqrt(a * b) / m;
  const double t_stop = phi0 / rate;
  const CoastResult r = coast(coasting_vehicle(road, v0), h, t_stop + 5.0);
  EXPECT_NEAR(r.speed_at_10s_m_s, std::sqrt(a / b) * std::tan(phi0 - 10.0 * rate), 1e-9);
  EXPECT_NEAR(r.stop_time_s, t_stop, 1e-6 * h);
  EXPECT_EQ(r.events, 1);
  EXPECT_TRUE(r.locked_at_end);
}

TEST(CoastDown, ChassisDynamometerFormMatchesClosedForm) {
  RoadLoadParams road;
  road.form = RoadLoadForm::kCoastDown;
  road.f0_N = 150.0;
  road.f1_N_s_m = 2.0;
  road.f2_N_s2_m2 = 0.4;
  const double m = 1300.0, v0 = 100.0 / 3.6, h = 1e-3;
  const double s = std::sqrt(4.0 * 150.0 * 0.4 - 2.0 * 2.0);
  const double phi0 = std::atan((2.0 * 0.4 * v0 + 2.0) / s);
  const auto speed = [&](double t) { return (s * std::tan(phi0 - t * s / (2.0 * m)) - 2.0) / (2.0 * 0.4); };
  const double t_stop = (2.0 * m / s) * (phi0 - std::atan(2.0 / s));
  const CoastResult r = coast(coasting_vehicle(road, v0), h, t_stop + 5.0);
  EXPECT_NEAR(r.speed_at_10s_m_s, speed(10.0), 1e-9);
  EXPECT_NEAR(r.stop_time_s, t_stop, 1e-6 * h);
  EXPECT_EQ(r.events, 1);
  EXPECT_TRUE(r.locked_at_end);
}

// The drive's rotor turns with the wheels, so it is decelerated too: a coasting car (driver
// gain 0, a real rotor of 0.25 kg m^2 behind G/r = 10.5 rad/m) under a constant force f0
// slows at f0 / (m + J (G/r)^2), 2 % less than f0 / m.
TEST(CoastDown, TheReflectedRotorInertiaSlowsTheDecelerationExactly) {
  RoadLoadParams road;
  road.form = RoadLoadForm::kCoastDown;
  road.f0_N = 300.0;
  road.f2_N_s2_m2 = 0.0;
  BevParams p = coasting_vehicle(road, 20.0);
  p.driver.gain = 0.0;
  p.drive.inertia_kgm2 = 0.25;
  const double g_over_r = p.body.gear_ratio / p.body.wheel_radius_m;
  const double m_eff = p.body.mass_kg + p.drive.inertia_kgm2 * g_over_r * g_over_r;
  ASSERT_GT(m_eff - p.body.mass_kg, 20.0);  // the rotor is worth ~28 kg
  const double h = 1e-3, t_stop = 20.0 * m_eff / 300.0;
  const CoastResult r = coast(p, h, t_stop + 2.0);
  EXPECT_NEAR(r.speed_at_10s_m_s, 20.0 - 300.0 * 10.0 / m_eff, 1e-9);
  EXPECT_NEAR(r.stop_time_s, t_stop, 1e-6 * h);
  EXPECT_EQ(r.events, 1);
}

TEST(RoadLoad, ForcesOpposeMotionAndSlopeActsBothWays) {
  RoadLoadParams p;
  p.rolling_coefficient = 0.01;
  p.frontal_area_m2 = 2.0;
  p.drag_coefficient = 0.3;
  p.slope_rad = Table1d({0.0, 100.0}, {0.0, 0.1}, Extrapolation::kHold);
  const RoadLoad r(p, 1000.0);
  EXPECT_GT(r.speed_force_N(10.0), 0.0);
  EXPECT_LT(r.speed_force_N(-10.0), 0.0);
  EXPECT_NEAR(r.grade_rad(50.0), 0.05, 1e-15);
  EXPECT_NEAR(r.grade_force_N(0.05), 1000.0 * kGravity_m_s2 * std::sin(0.05), 1e-9);
  EXPECT_NEAR(r.rolling_N(0.05), 0.01 * 1000.0 * kGravity_m_s2 * std::cos(0.05), 1e-9);
  EXPECT_EQ(motion_at_rest(10.0, 20.0), Motion::kStuck);
  EXPECT_EQ(motion_at_rest(25.0, 20.0), Motion::kForward);
  EXPECT_EQ(motion_at_rest(-25.0, 20.0), Motion::kBackward);
  EXPECT_EQ(motion_at_rest(0.0, 0.0), Motion::kStuck);
}

}  // namespace
}  // namespace ehpt::plant
