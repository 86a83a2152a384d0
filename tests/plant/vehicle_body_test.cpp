// SPDX-License-Identifier: BSD-3-Clause
// The vehicle body both vehicles share (MODELS.md §7): forces, brake, the body's states'
// derivatives, the crossings of its modes.
#include "plant/vehicle_body.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ehpt::plant {
namespace {

VehicleBody body_on_a_slope(double angle_rad) {
  RoadLoadParams road;
  road.rolling_coefficient = 0.014;
  road.frontal_area_m2 = 2.2;
  road.drag_coefficient = 0.26;
  road.slope_rad = Table1d({0.0, 1000.0}, {angle_rad, angle_rad}, Extrapolation::kHold);
  return VehicleBody({.mass_kg = 1300.0, .wheel_radius_m = 0.5, .gear_ratio = 5.0}, road, BrakeParams{});
}

TEST(VehicleBody, ForcesBrakeAndTheBodysDerivatives) {
  const VehicleBody body = body_on_a_slope(0.05);
  const VehicleBody::Forces f = body.forces(10.0, 100.0);
  const double mg = 1300.0 * kGravity_m_s2;
  EXPECT_DOUBLE_EQ(f.grade_rad, 0.05);
  EXPECT_NEAR(f.rolling_N, 0.014 * mg * std::cos(0.05), 1e-9);
  EXPECT_NEAR(f.speed_force_N, 0.5 * 1.226 * 2.2 * 0.26 * 100.0, 1e-9);
  EXPECT_NEAR(f.grade_force_N, mg * std::sin(0.05), 1e-9);
  EXPECT_EQ(body.brake_N(-3.0), 0.0);                // no unmet braking: no brake
  EXPECT_DOUBLE_EQ(body.brake_N(2.0), 2.0 * 10.0);  // G / r = 10 N per N m
  double dx[VehicleBody::kNumStates] = {};
  body.derivatives(-10.0, f, 40.0, dx);  // backward at 10 m/s
  EXPECT_EQ(dx[VehicleBody::kDistance], -10.0);
  EXPECT_NEAR(dx[VehicleBody::kAltitude], -10.0 * std::sin(0.05), 1e-12);
  EXPECT_NEAR(dx[VehicleBody::kRoadJ], f.rolling_N * 10.0 - f.speed_force_N * 10.0, 1e-9);
  EXPECT_EQ(dx[VehicleBody::kBrakeJ], 400.0);  // dissipation is positive either way
  // resisting force against +v: road, grade and brake oppose the motion, the grade does not flip
  EXPECT_DOUBLE_EQ(VehicleBody::resisting_N(Motion::kForward, f, 40.0),
                   f.rolling_N + f.speed_force_N + f.grade_force_N + 40.0);
  EXPECT_DOUBLE_EQ(VehicleBody::resisting_N(Motion::kBackward, f, 40.0),
                   -f.rolling_N + f.speed_force_N + f.grade_force_N - 40.0);
  EXPECT_EQ(VehicleBody::resisting_N(Motion::kStuck, f, 40.0), 0.0);
}

TEST(VehicleBody, EachModeHasOneCrossingThatFallsThroughZero) {
  EXPECT_EQ(VehicleBody::moving_crossing(Motion::kForward, 2.0), 2.0);
  EXPECT_EQ(VehicleBody::moving_crossing(Motion::kBackward, -2.0), 2.0);
  EXPECT_EQ(VehicleBody::moving_crossing(Motion::kForward, -0.5), -0.5);  // passed zero: fires
  EXPECT_GT(VehicleBody::stuck_crossing(100.0, 178.5), 0.0);               // held
  EXPECT_LT(VehicleBody::stuck_crossing(-200.0, 178.5), 0.0);              // breaks away, backward
}

}  // namespace
}  // namespace ehpt::plant
