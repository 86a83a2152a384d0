// SPDX-License-Identifier: BSD-3-Clause
#include "plant/map_drive.hpp"

#include <gtest/gtest.h>

#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

MapDriveParams one_flange_test_drive() {
  // TestMBOneFlange (§11.1) with the EVmaps map as in vehicles/test_mb_one_flange.toml
  const BevParams ev = test::mbev();
  MapDriveParams p;
  p.torque_max_Nm = 50.0;
  p.power_max_W = 10000.0;
  p.speed_max_rad_s = 300.0;
  p.inertia_kgm2 = 0.5;
  p.loss_model = DriveLossModel::kMap;
  p.efficiency_map = ev.drive.efficiency_map;
  return p;
}

TEST(MapDrive, LimiterStatesFollowSection13) {
  const MapDrive d(one_flange_test_drive());  // w_base = 200 rad/s
  EXPECT_EQ(d.torque_limit(100.0).state, 0);
  EXPECT_DOUBLE_EQ(d.torque_limit(100.0).torque_Nm, 50.0);
  EXPECT_EQ(d.torque_limit(250.0).state, 1);
  EXPECT_DOUBLE_EQ(d.torque_limit(250.0).torque_Nm, 40.0);
  EXPECT_EQ(d.torque_limit(315.0).state, 2);  // half-way through the 10 % ramp
  EXPECT_NEAR(d.torque_limit(315.0).torque_Nm, 10000.0 / 300.0 * 0.5, 1e-12);
  EXPECT_EQ(d.torque_limit(331.0).state, 3);
  EXPECT_DOUBLE_EQ(d.torque_limit(331.0).torque_Nm, 0.0);
  // |w| is used: the same limits backwards
  EXPECT_EQ(d.torque_limit(-250.0).state, 1);
}

TEST(MapDrive, ClampsBothSidesAndFlagsLimiting) {
  const MapDrive d(one_flange_test_drive());
  const DriveOperatingPoint up = d.operate(80.0, 100.0);
  EXPECT_DOUBLE_EQ(up.torque_Nm, 50.0);
  EXPECT_TRUE(up.limiting);
  const DriveOperatingPoint down = d.operate(-80.0, 100.0);
  EXPECT_DOUBLE_EQ(down.torque_Nm, -50.0);
  EXPECT_FALSE(d.operate(20.0, 100.0).limiting);
}

TEST(MapDrive, EfficiencyMapPerUnitTorqueRowsAndDcPowerSign) {
  const MapDrive d(one_flange_test_drive());
  // grid point torque 0.5 p.u. (25 N m), speed 0.5 p.u. (150 rad/s): 0.83 (torque rows)
  EXPECT_NEAR(d.efficiency(25.0, 150.0), 0.83, 1e-12);
  // torque 1 p.u., speed 0.25 p.u.: 0.84 (the transposed map would give 0.78)
  EXPECT_NEAR(d.efficiency(50.0, 75.0), 0.84, 1e-12);
  const DriveOperatingPoint motoring = d.operate(25.0, 150.0);
  EXPECT_NEAR(motoring.power_dc_W, 25.0 * 150.0 / 0.83, 1e-9);
  const DriveOperatingPoint generating = d.operate(-25.0, 150.0);
  EXPECT_NEAR(generating.power_dc_W, -25.0 * 150.0 * 0.83, 1e-9);
  // beyond the grid: linear extrapolation from the last two lines, floored at 0.01
  EXPECT_NEAR(d.efficiency(25.0, 330.0), 0.85 + (0.85 - 0.84) * 0.4, 1e-12);
}

TEST(MapDrive, LossFormulaAndIdeal) {
  MapDriveParams p = one_flange_test_drive();
  p.loss_model = DriveLossModel::kFormula;
  const MapDrive d(p);
  const double tu = 0.5, wu = 0.5, pu = tu * wu;
  const double loss = 0.006 + 0.05 * tu * tu + 0.02 * wu * wu + 0.05 * pu * pu;
  EXPECT_NEAR(d.efficiency(25.0, 150.0), pu / (pu + loss), 1e-12);
  EXPECT_DOUBLE_EQ(d.operate(0.0, 150.0).power_dc_W, 0.0);
  p.loss_model = DriveLossModel::kIdeal;
  EXPECT_DOUBLE_EQ(MapDrive(p).operate(25.0, 150.0).power_dc_W, 3750.0);
}

TEST(MapDrive, ValidateRejectsBadValues) {
  MapDriveParams p = one_flange_test_drive();
  p.torque_max_Nm = -1.0;
  p.efficiency_map = Table2d({0.0, 1.0}, {0.0, 1.0}, {0.9, 1.2, 0.8, 0.9});
  Problems problems;
  validate(p, "drive", problems);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(problems.list()[0].field, "drive.torque_max_Nm");
  EXPECT_EQ(problems.list()[1].value, "1.2");
}

}  // namespace
}  // namespace ehpt::plant
