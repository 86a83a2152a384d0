// SPDX-License-Identifier: BSD-3-Clause
// The power-split hybrid (MODELS.md §4, §5, §10.4) with its built-in ECUs.
#include "ecu/psd_ecu.hpp"
#include "plant/psd_plant.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "hil/run/runner.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

using ecu::PsdEcu;
using ecu::PsdEcuParams;
using PsdRunner = hil::Runner<PsdPlant, solvers::Rk4<PsdPlant>, PsdEcu>;

// A PSecu scenario's plant and ECU, through the real loader.
struct Psecu {
  PsdParams plant;
  PsdEcuParams ecu;
};
Psecu psecu(const std::string& scenario, const std::vector<std::string>& overrides = {}) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/" + scenario), overrides);
  return {sc.plant.get<PsdParams>(), sc.ecu.get<PsdEcuParams>()};
}

// What a drive() returns: the runner's counters and metrics.
struct Driven {
  hil::RunStats stats;
  hil::MetricTotals metrics;
};

// Steps a PSD vehicle with its ECU every step of 1 ms and calls f(n, t, x, modes, outputs).
template <class F>
Driven drive(const Psecu& p, double duration_s, F f, EnergyAudit* audit = nullptr) {
  const PsdPlant plant(p.plant);
  PsdEcu ecu(p.ecu, 1e-3);
  const auto steps = std::llround(duration_s / 1e-3);
  PsdRunner runner(plant, {.total_steps = steps, .decimation = steps, .columns = {0}, .chunk_steps = 1}, &ecu);  // one step per run(): observe each
  while (!runner.finished()) {
    runner.run();
    runner.clear_rows();
    f(runner.step_index(), runner.time_s(), runner.state(), runner.modes(), runner.last_outputs());
  }
  if (audit != nullptr) *audit = plant.audit(runner.initial_state(), runner.state());
  return {runner.stats(), runner.metrics()};
}

TEST(Planetary, WillisAndTheTorqueBalanceHoldAtEveryStep) {
  const Psecu setup = psecu("psecu2_nedc.toml");
  const PsdParams& p = setup.plant;
  const PsdPlant plant(p);
  const double rho = p.ring_sun_ratio, ratio = p.body.wheel_radius_m / p.body.gear_ratio;
  int checked = 0;
  drive(setup, 400.0, [&](std::int64_t n, double t, const PsdPlant::State& x, const PsdPlant::Modes& m,
                      const PsdPlant::Outputs& y) {
    // Willis on the reported speeds: (1 + rho) w_c = w_s + rho w_r (the sun speed is derived
    // from it, so this guards the outputs, not the dynamics)
    const double lhs = (1.0 + rho) * y.iceW_rad_s, rhs = y.genW_rad_s + rho * y.motW_rad_s;
    ASSERT_LE(std::abs(lhs - rhs), 1e-9 * std::max(1.0, std::abs(lhs))) << t;
    // the massless, lossless gear neither stores nor loses power: what the engine, gen and
    // mot deliver at their flanges (bus signals, from the solved accelerations) sums to zero
    const double flange_sum = y.icePowDel_W + y.genPowDel_W + y.motPowDelA_W;
    const double flange_scale = std::abs(y.icePowDel_W) + std::abs(y.genPowDel_W) + std::abs(y.motPowDelA_W);
    ASSERT_LE(std::abs(flange_sum), 1e-9 * flange_scale + 1e-9) << t;
    if (n % 997 != 0 || m.motion == Motion::kStuck) return;
    // torques the outside applies to the three flanges of the massless gear
    msgs::PsdCommand bus;
    bus.icePowRef_W = y.icePowRef_W;
    bus.genTauRef_Nm = y.genTauRef_Nm;
    bus.motTauRef_Nm = y.motTauRef_Nm;
    bus.iceON = y.iceON != 0.0;
    const PsdPlant::Eval e = plant.evaluate(t, x, m, bus);
    const double sun_accel = (1.0 + rho) * e.ice_accel_rad_s2 - rho * e.ring_accel_rad_s2;
    const double tau_s = e.gen.torque_Nm - p.gen.inertia_kgm2 * sun_accel;
    const double tau_c = e.ice_torque_Nm - p.ice.inertia_kgm2 * e.ice_accel_rad_s2;
    const double wheel_force_N = p.body.mass_kg * e.ring_accel_rad_s2 * ratio + e.rolling_N + e.speed_force_N +
                                 e.grade_force_N + e.brake_N;
    const double tau_r = e.mot.torque_Nm - p.mot.inertia_kgm2 * e.ring_accel_rad_s2 - ratio * wheel_force_N;
    const double scale = std::max({1.0, std::abs(tau_s), std::abs(tau_c)});
    ASSERT_NEAR(tau_c, -(1.0 + rho) * tau_s, 1e-9 * scale) << t;
    ASSERT_NEAR(tau_r, rho * tau_s, 1e-9 * scale) << t;
    ASSERT_NEAR(tau_s * e.sun_speed_rad_s + tau_r * x[PsdPlant::kRingSpeed] + tau_c * x[PsdPlant::kIceSpeed], 0.0,
                1e-9 * scale * std::abs(x[PsdPlant::kIceSpeed]) + 1e-9);
    ++checked;
  });
  EXPECT_GT(checked, 100);
}

TEST(PsdPlant, EngineOffBurnsNoFuelAndGivesNoTorque) {
  PsdParams p = psecu("psecu2_nedc.toml").plant;
  const PsdPlant plant(p);
  PsdPlant::State x = plant.initial_state();
  x[PsdPlant::kIceSpeed] = 200.0;
  msgs::PsdCommand bus;
  bus.icePowRef_W = 20000.0;
  bus.iceON = false;
  PsdPlant::State dx;
  plant.derivatives(0.0, x, {Motion::kStuck}, bus, dx);
  EXPECT_EQ(dx[PsdPlant::kFuelKg], 0.0);
  EXPECT_EQ(dx[PsdPlant::kIceWorkJ], 0.0);
  bus.iceON = true;
  plant.derivatives(0.0, x, {Motion::kStuck}, bus, dx);
  EXPECT_GT(dx[PsdPlant::kFuelKg], 0.0);
}

TEST(MBecu2, HysteresisOnAbove7kWOffBelow5kWWithoutChattering) {
  PsdEcuParams p = psecu("psecu2_nedc.toml").ecu;
  p.soc_loop_gain_W = 0.0;   // P_add = P_avg
  p.power_filter_s = 1e-9;   // P_avg follows motPowDelB within one period
  PsdEcu ecu(p, 1e-3);
  msgs::PsdSensors in;
  msgs::PsdCommand bus;
  std::vector<std::pair<double, bool>> switches;
  bool on = false;
  // a triangle 0 -> 10 kW -> 0 with +-800 W of noise: inside the 2 kW band it must not chatter
  for (int k = 0; k < 20000; ++k) {
    const double base = k < 10000 ? k : 20000 - k;
    in.motPowDelB_W = base + 800.0 * std::sin(0.7 * k);
    ecu.update(in, bus);
    if (bus.iceON != on) {
      switches.emplace_back(base, bus.iceON);
      on = bus.iceON;
    }
    if (bus.iceON) {
      EXPECT_GT(bus.icePowRef_W, 5000.0 - 1e-9);
    } else {
      EXPECT_EQ(bus.icePowRef_W, 0.0);
    }
  }
  ASSERT_EQ(switches.size(), 2u);
  EXPECT_TRUE(switches[0].second);
  EXPECT_GT(switches[0].first + 800.0, 7000.0);  // P_add was above 7 kW
  EXPECT_FALSE(switches[1].second);
  EXPECT_LT(switches[1].first - 800.0, 5000.0);  // below 5 kW
}

TEST(PsdEcu, FiltersAreExactForHeldInputs) {
  PsdEcuParams p = psecu("psecu2_nedc.toml").ecu;
  const double ts = 0.01;
  PsdEcu ecu(p, ts);
  msgs::PsdSensors in;
  msgs::PsdCommand out;
  in.motPowDelB_W = 1000.0;
  in.batSOC = p.soc_ref;
  for (int k = 0; k < 6000; ++k) ecu.update(in, out);  // 60 s = one filter time constant
  EXPECT_NEAR(ecu.power_average_W(), 1000.0 * (1.0 - std::exp(-1.0)), 1e-9);
  in.driverRequest = 0.5;
  ecu.update(in, out);
  EXPECT_EQ(out.motTauRef_Nm, 40.0);  // 80 N m per unit request
}

TEST(PaperPsecu2OnNedc, FollowsHoldsSocSwitchesTheEngineAndBalancesEnergy) {
  const Psecu setup = psecu("psecu2_nedc.toml");
  const PsdParams& p = setup.plant;
  double first_on_s = -1.0, soc_end = 0.0, max_err_urban = 0.0, sq = 0.0, max_err = 0.0, dist = 0.0;
  double creep_m = 0.0;
  bool locked_at_11s = false;
  std::int64_t samples = 0;
  EnergyAudit audit;
  const Driven st = drive(
      setup, 1400.0,
      [&](std::int64_t, double t, const PsdPlant::State& x, const PsdPlant::Modes&, const PsdPlant::Outputs& y) {
        if (first_on_s < 0.0 && y.iceON != 0.0) first_on_s = t;
        // standing while gen spins the engine up from 50 to 125 rad/s (§4.3)
        if (t < 11.0) creep_m = std::max(creep_m, std::abs(x[PsdPlant::kDistance]));
        if (std::abs(t - 10.9) < 1e-9) locked_at_11s = y.locked != 0.0;
        const double e = 3.6 * (y.speed_ref_m_s - y.speed_m_s);
        sq += e * e;
        ++samples;
        max_err = std::max(max_err, std::abs(e));
        if (t < 780.0) max_err_urban = std::max(max_err_urban, std::abs(e));
        soc_end = y.soc;
        dist = y.distance_m;
      },
      &audit);
  // starts OFF (P_add(0) = 2.5 kW, §5.4); with the drives' losses the battery drains faster
  // than in the eta = 1 set-up of §5.4 (first switch-on ~337 s, tested below), so the SOC
  // loop starts the engine at 145.5 s
  EXPECT_NEAR(first_on_s, 145.5, 1.0);
  // the gen's reaction on the ring peaks at 181 N against a 178.5 N break-away force (the
  // re-simulation of §4.3 saw 172 N with an engine that gives torque while OFF): the car
  // creeps back by a fraction of a millimetre, then is held again before the cycle starts
  EXPECT_LT(creep_m, 1e-3);
  EXPECT_TRUE(locked_at_11s);
  EXPECT_EQ(st.stats.chattering_steps, 0);
  EXPECT_EQ(st.metrics.engine_starts, 5);  // 145.5, 334.7, 526.8, 721.0, 822.8 s
  // stated limits: the library's driver (k = 1 per m/s, 80 N m per unit) lags in the
  // accelerations by up to ~5.5 km/h; its request saturates at 1.8 per unit in the final
  // 120 -> 0 km/h braking, where the engine, still ON, pushes on the ring and the car falls
  // up to ~16 km/h behind (the friction brake supplies only what mot cannot)
  EXPECT_LT(std::sqrt(sq / samples), 2.5);
  EXPECT_LT(max_err_urban, 6.0);
  EXPECT_LT(max_err, 17.0);
  EXPECT_NEAR(dist, 10983.0, 0.01 * 10983.0);
  EXPECT_LT(std::abs(soc_end - 0.6), 0.05);
  EXPECT_LE(std::abs(audit.residual_J), 1e-6 * audit.scale_J);
  // the fuel term cancels in the balance, so check it on its own: the average specific
  // consumption (fuel / engine work) must lie inside the sfc map (228..630 g/kWh) and near
  // its best region, where MBecu2 keeps the engine (~90 N m, P15 rule 1)
  double fuel_J = 0.0, work_J = 0.0;
  for (const auto& [name, value] : audit.terms) {
    if (name == "fuel_chemical_J") fuel_J = value;
    if (name == "engine_work_J") work_J = value;
  }
  const double avg_sfc_g_kWh = fuel_J / p.ice.fuel_lhv_J_kg * 1e3 / (work_J / 3.6e6);
  EXPECT_GT(avg_sfc_g_kWh, 228.0);
  EXPECT_LT(avg_sfc_g_kWh, 270.0);
}

// The example source's set-up (gen and mot at eta = 1, MODELS.md §10.4 table): the
// re-simulation of §5.4 switches the engine on first at ~337 s.
TEST(PaperPsecu2OnNedc, TheSourceSetUpStartsTheEngineAt337s) {
  const Psecu p = psecu("psecu2_source_nedc.toml");
  EXPECT_EQ(p.plant.gen.loss_model, DriveLossModel::kIdeal);
  EXPECT_EQ(p.plant.mot.loss_model, DriveLossModel::kIdeal);
  double first_on_s = -1.0;
  const Driven st = drive(p, 1400.0, [&](std::int64_t, double t, const auto&, const auto&, const auto& y) {
    if (first_on_s < 0.0 && y.iceON != 0.0) first_on_s = t;
  });
  EXPECT_NEAR(first_on_s, 337.0, 1.0);
  EXPECT_EQ(st.metrics.engine_starts, 4);  // 336.8, 532.2, 727.5, 827.8 s
}

// The library tutorial's published figures on NEDC at t = 1250 s: fuel 0.356 kg for the
// ON/OFF hybrid (ehpt psecu2), 0.449 kg for the always-on one with SOC loop (psecu1soc), a
// saving of more than 20 %, with both cars ending near the same SOC as the tutorial says was
// intended. They need the drives' efficiency maps (the vehicles' default); at eta = 1 the
// same cars give 279 g and 384 g. And without a SOC loop (MBecu1) the SOC shifts by a
// "non-negligible" amount (tutorial, MODELS.md §5.2).
TEST(TutorialFigures, PowerSplitFuelAt1250sOnNedc) {
  struct End {
    double fuel_kg = 0.0, soc = 0.0;
  };
  const auto run = [](const char* scenario) {
    End e;
    drive(psecu(scenario), 1250.0, [&](std::int64_t, double, const auto&, const auto&, const auto& y) {
      e.fuel_kg = y.fuel_g / 1000.0;
      e.soc = y.soc;
    });
    return e;
  };
  const End on_off = run("psecu2_nedc.toml"), always_on = run("psecu1soc_nedc.toml"), no_loop = run("psecu1_nedc.toml");
  EXPECT_NEAR(on_off.fuel_kg, 0.356, 0.02 * 0.356);      // ehpt: 0.3582
  EXPECT_NEAR(always_on.fuel_kg, 0.449, 0.02 * 0.449);   // ehpt: 0.4536
  EXPECT_GT(1.0 - on_off.fuel_kg / always_on.fuel_kg, 0.20);  // ehpt: 21.0 %
  EXPECT_NEAR(on_off.soc, always_on.soc, 0.005);         // ehpt: 0.6040 and 0.6061
  EXPECT_NEAR(on_off.soc, 0.6, 0.01);
  EXPECT_GT(std::abs(no_loop.soc - 0.6), 0.1);           // ehpt: 0.6 -> 0.411
}

TEST(PaperPsecu2OnNedc, OnOffEngineUsesAtLeast20PercentLessFuelThanAlwaysOn) {
  const Psecu on_off = psecu("psecu2_nedc.toml");
  const Psecu always = psecu("psecu2_nedc.toml", {"vehicle.ecu.kind=MBecu1soc"});
  double fuel_on_off = 0.0, fuel_always = 0.0;
  drive(on_off, 1400.0, [&](std::int64_t, double, const auto&, const auto&, const auto& y) { fuel_on_off = y.fuel_g; });
  drive(always, 1400.0, [&](std::int64_t, double, const auto&, const auto&, const auto& y) { fuel_always = y.fuel_g; });
  EXPECT_GT(fuel_always, 0.0);
  EXPECT_LT(fuel_on_off, 0.8 * fuel_always);
}

TEST(PsdOnNedc, EveryEcuClosesTheEnergyBalanceAndTheAlwaysOnEngineRunsThroughout) {
  for (const char* s : {"psecu1_nedc.toml", "psecu1soc_nedc.toml"}) {
    EnergyAudit audit;
    const Driven st = drive(psecu(s), 1400.0, [](std::int64_t, double, const auto&, const auto&, const auto&) {},
                                   &audit);
    EXPECT_LE(std::abs(audit.residual_J), 1e-6 * audit.scale_J) << s;
    EXPECT_EQ(st.metrics.engine_starts, 1) << s;
    EXPECT_NEAR(st.metrics.engine_on_time_s, 1400.0, 1e-6) << s;
  }
}

TEST(PsdEcu, RunsEveryWholeNumberOfSteps) {
  // 10 ms ECU on a 1 ms plant: the same vehicle, a slightly different but close trajectory
  const hil::Scenario sc =
      test::load(test::source_path("scenarios/psecu2_nedc.toml"), {"vehicle.ecu.period_s=0.01"});
  EXPECT_EQ(sc.solver.ecu_ratio, 10);
  hil::Scenario bad;
  std::vector<std::string> errors;
  EXPECT_FALSE(hil::load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {"vehicle.ecu.period_s=0.0015"},
                                  bad, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("ecu.period_s = 0.0015: must be a whole multiple of solver.step_s = 0.001"),
            std::string::npos);
}

}  // namespace
}  // namespace ehpt::plant
