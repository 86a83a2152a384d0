// SPDX-License-Identifier: BSD-3-Clause
// Map-based ICE (MODELS.md §3) and the ICE test set-ups of §11.4.
#include "plant/psd_plant.hpp"
#include "plant/map_ice.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "hil/config/config.hpp"
#include "plant/drive_rigs.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

MapIceParams psd_ice() {
  return test::load(test::source_path("scenarios/psecu2_nedc.toml")).plant.get<PsdParams>().ice;
}

TEST(MapIce, FuelFlowIsSfcTimesPower) {
  const MapIce ice(psd_ice());
  // grid point 50 N m, 300 rad/s: 265 g/kWh at 15 kW -> 3975 g/h
  EXPECT_NEAR(ice.sfc_g_kWh(50.0, 300.0), 265.0, 1e-12);
  EXPECT_NEAR(ice.fuel_rate_kg_s(50.0, 300.0), 265.0 * 15.0 / 3600.0 / 1000.0, 1e-15);
  // between grid points: bilinear (torque rows 80/90, speed columns 200/300)
  const double sfc = 0.5 * (0.5 * (230 + 233) + 0.5 * (230 + 228));
  EXPECT_NEAR(ice.sfc_g_kWh(85.0, 250.0), sfc, 1e-12);
  EXPECT_NEAR(ice.fuel_rate_kg_s(85.0, 250.0), sfc * 85.0 * 250.0 / 3.6e9, 1e-15);
  // no torque, no fuel; below the grid the sfc rises (linear extrapolation) but stays >= 0
  EXPECT_EQ(ice.fuel_rate_kg_s(0.0, 300.0), 0.0);
  EXPECT_GT(ice.sfc_g_kWh(5.0, 300.0), 550.0);
  EXPECT_GE(ice.sfc_g_kWh(-100.0, 300.0), 0.0);
}

TEST(MapIce, TorqueRequestsAreClampedToTheCurve) {
  const MapIce ice(psd_ice());
  EXPECT_EQ(ice.torque_for_request_Nm(-10.0, 200.0), 0.0);
  EXPECT_EQ(ice.torque_for_request_Nm(50.0, 200.0), 50.0);
  EXPECT_EQ(ice.torque_for_request_Nm(120.0, 200.0), 85.0);
  EXPECT_EQ(ice.torque_for_request_Nm(120.0, 50.0), 80.0);   // below the table: end value held
  EXPECT_EQ(ice.torque_for_request_Nm(120.0, 450.0), 98.0);
}

TEST(MapIce, PowerLoopSolvesTheAlgebraicLoopExactly) {
  const MapIce ice(psd_ice());
  const double w = 200.0, a0 = -3.0, a1 = 0.4, p_ref = 9000.0, j = 0.5, k = 0.1;
  const double tau = ice.torque_for_power_Nm(p_ref, w, a0, a1);
  const double pow_del = (tau - j * (a0 + a1 * tau)) * w;  // icePowDel with that torque
  EXPECT_NEAR(tau, k * (p_ref - pow_del), 1e-9);
  EXPECT_EQ(ice.torque_for_power_Nm(-5000.0, w, a0, a1), 0.0);        // never motors the shaft
  EXPECT_EQ(ice.torque_for_power_Nm(1e7, w, a0, a1), 85.0);           // curve at 200 rad/s
}

TEST(MapIce, ValidateRejectsNegativeSfcAndBadCurves) {
  MapIceParams p = psd_ice();
  p.sfc_g_kWh = Table2d({10, 20}, {100, 200}, {300, -1, 250, 260});
  p.torque_max_Nm = Table1d({100, 300, 200}, {80, 85, 90}, Extrapolation::kHold);
  Problems problems;
  validate(p, "ice", problems);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(problems.list()[0].field, "ice.torque_max");
  EXPECT_EQ(problems.list()[0].row, 2);
  EXPECT_EQ(problems.list()[1].field, "ice.sfc_map");
  EXPECT_EQ(problems.list()[1].row, 1);     // the second grid point in file order
  EXPECT_EQ(problems.list()[1].column, 2);  // the value column
  EXPECT_EQ(problems.list()[1].value, "-1");
}

// §11.4 rigs: ICE + load inertia + quadratic load -80 (w/100)^2 N m; the request is a
// trapezoid (a torque, or a power for the power-input engine), held over each step with the
// ON flag, as an ECU would send them. Torque and fuel come from MapIce itself.
struct IceRig {
  static constexpr int kNumStates = 3;  // w, fuel kg, engine work J
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {
    double request = 0.0;  // N m or W
    bool on = true;
  };
  MapIce ice;
  double load_inertia_kgm2;
  Trapezoid request;
  double off_from_s = -1.0, off_to_s = -1.0;

  double inertia() const { return ice.params().inertia_kgm2 + load_inertia_kgm2; }
  double load_Nm(double w) const { return -80.0 * (w / 100.0) * (w / 100.0); }
  Inputs inputs(double t) const {
    return {trapezoid(request, t), !(t >= off_from_s - 1e-9 && t < off_to_s - 1e-9)};
  }
  double torque(const Inputs& u, double w) const {
    // dw/dt = a0 + a1 tau with the load inertia on the same shaft
    return ice.torque_Nm(u.on, u.request, u.request, w, load_Nm(w) / inertia(), 1.0 / inertia());
  }
  void derivatives(double, const State& x, const Modes&, const Inputs& u, State& dx) const {
    const double tau = torque(u, x[0]);
    dx[0] = (tau + load_Nm(x[0])) / inertia();
    dx[1] = ice.fuel_rate_kg_s(u.on, tau, x[0]);
    dx[2] = tau * x[0];
  }
  // icePowDel: power at the engine flange
  double power_delivered_W(const Inputs& u, double w) const {
    const double tau = torque(u, w);
    return (tau - ice.params().inertia_kgm2 * (tau + load_Nm(w)) / inertia()) * w;
  }
};

MapIce ice_with(IceInput input, double gain, bool on_off) {
  MapIceParams p = psd_ice();
  p.input = input;
  p.control_gain_Nm_W = gain;
  p.on_off = on_off;
  return MapIce(p);
}

template <class F>
void simulate(const IceRig& rig, double w0, double t_end, F each_step) {
  solvers::Rk4<IceRig> rk4(rig);
  IceRig::State x(w0, 0.0, 0.0);
  const double h = 1e-3;
  for (int n = 0; n * h < t_end; ++n) {
    each_step(n * h, x);
    rk4.step(n * h, h, {}, rig.inputs(n * h), x);
  }
}

TEST(IceTestRigs, TestIceTRequestAboveTheCurveIsTorqueLimited) {
  // V3 TestIceT: request 50 -> 85 N m, start 78 rad/s, PSDmaps max-torque curve
  IceRig rig{ice_with(IceInput::kTorque, 0.1, false), 0.5, {50.0, 35.0, 10.0, 10.0, 10.0, 10.0, 1e6}};
  bool limited = false;
  simulate(rig, 78.0, 60.0, [&](double t, const IceRig::State& x) {
    const double tau = rig.torque(rig.inputs(t), x[0]);
    EXPECT_LE(tau, rig.ice.torque_max_Nm(x[0]) + 1e-12);
    if (t > 20.0 && t < 30.0) limited = limited || tau < trapezoid(rig.request, t) - 1.0;
    if (t < 10.0) {
      EXPECT_EQ(tau, 50.0);
    }
  });
  EXPECT_TRUE(limited);  // 85 N m is above the 80-85 N m curve at these speeds
}

TEST(IceTestRigs, TestIcePProportionalLoopLeavesASteadyError) {
  // TestIceP: contrGain 1, request 4 -> 6 kW, start 80 rad/s; at steady state
  // P_ref - icePowDel = tau / K (no integral action)
  IceRig rig{ice_with(IceInput::kPower, 1.0, false), 0.5, {4000.0, 2000.0, 10.0, 10.0, 10.0, 10.0, 1e6}};
  double w_at_9 = 0.0, w_at_29 = 0.0;
  simulate(rig, 80.0, 30.0, [&](double t, const IceRig::State& x) {
    if (std::abs(t - 9.0) < 5e-4) w_at_9 = x[0];
    if (std::abs(t - 29.0) < 5e-4) w_at_29 = x[0];
  });
  for (const auto& [t, w, p_ref] : {std::tuple{9.0, w_at_9, 4000.0}, std::tuple{29.0, w_at_29, 6000.0}}) {
    const double tau = rig.torque(rig.inputs(t), w);
    const double p_del = rig.power_delivered_W(rig.inputs(t), w);
    EXPECT_LT(p_del, p_ref);                          // below the request...
    EXPECT_NEAR(p_ref - p_del, tau / 1.0, 1e-6 * p_ref);  // ...by tau / K
    EXPECT_NEAR(tau, -rig.load_Nm(w), 1e-3);          // and at the load's steady state
  }
}

TEST(IceTestRigs, TestIceConnOONoPowerAndNoFuelWhileOff) {
  // TestIceConnOO: request 4 -> 6 kW, start 80 rad/s, engine OFF between 25 and 30 s
  IceRig rig{ice_with(IceInput::kPower, 0.5, true), 10.0, {4000.0, 2000.0, 10.0, 10.0, 10.0, 10.0, 1e6}, 25.0, 30.0};
  double fuel_at_25 = -1.0, fuel_at_30 = -1.0, fuel_at_31 = -1.0;
  simulate(rig, 80.0, 40.0, [&](double t, const IceRig::State& x) {
    if (!rig.inputs(t).on) {
      EXPECT_EQ(rig.torque(rig.inputs(t), x[0]), 0.0);
    }
    if (std::abs(t - 25.0) < 5e-4) fuel_at_25 = x[1];
    if (std::abs(t - 30.0) < 5e-4) fuel_at_30 = x[1];
    if (std::abs(t - 31.0) < 5e-4) fuel_at_31 = x[1];
  });
  EXPECT_GT(fuel_at_25, 0.0);
  EXPECT_EQ(fuel_at_30, fuel_at_25);  // no fuel while OFF
  EXPECT_GT(fuel_at_31, fuel_at_30);  // and again once ON
}

}  // namespace
}  // namespace ehpt::plant
