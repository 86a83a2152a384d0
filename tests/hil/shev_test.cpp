// SPDX-License-Identifier: BSD-3-Clause
// The series hybrid (MODELS.md §5.5, §10.6): its EMS on its own (the filter, the clamp, the
// ON/OFF hysteresis at the sampling instants), and the library's examples (and OO_noMaps) on Sort1
// and NEDC through the shipped scenarios: what each run gives with the model files' parameters,
// the energy audit, the faults, the vehicle files' numbers read back. Where the library's tutorial
// quotes other figures, the test says which and why (docs/validation.md, "Series hybrid").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "ecu/shev_ems.hpp"
#include "hil/config/config.hpp"
#include "hil/run/runner.hpp"
#include "plant/shev_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using ecu::ShevEms;
using ecu::ShevEmsParams;

ShevEmsParams shipped_ems(const char* scenario) {
  return test::load(test::source_path(std::string("scenarios/") + scenario)).ecu.get<ShevEmsParams>();
}

TEST(ShevEms, TheFilterIsExactForAHeldInput) {
  ShevEmsParams p = shipped_ems("shev_power_filt_sort1.toml");
  ASSERT_EQ(p.power_filter_s, 500.0);
  ASSERT_EQ(p.power_filter_initial_W, 20000.0);
  ShevEms ems(p, 0.01);
  msgs::ShevSensors in;
  msgs::ShevCommand out;
  in.drivePowDc_W = 1000.0;
  for (int k = 0; k < 50000; ++k) ems.update(in, out);  // 500 s = one time constant
  EXPECT_NEAR(ems.power_filtered_W(), 1000.0 + 19000.0 * std::exp(-1.0), 1e-7);
  in.driverRequest_Nm = 321.5;
  ems.update(in, out);
  EXPECT_EQ(out.driveTauRef_Nm, 321.5);  // the drive follows the driver
  EXPECT_TRUE(out.gensetON);
}

TEST(ShevEms, PowerFiltIgnoresTheSocAndClampsTo0AndPowerMax) {
  ShevEmsParams p = shipped_ems("shev_power_filt_sort1.toml");
  p.soc_gain_W = 1e6;  // PowerFilt has no SOC loop, whatever the field says
  p.power_filter_s = 1e-9;  // P_f follows the input within one period
  ShevEms ems(p, 0.01);
  msgs::ShevSensors in;
  msgs::ShevCommand out;
  in.batSOC = 0.0;
  for (const double pow_W : {5e4, -3e4, 2e5, 7e3}) {
    in.drivePowDc_W = pow_W;
    ems.update(in, out);  // P_f takes the input here: it shows in the next update
    ems.update(in, out);
    EXPECT_EQ(out.gensetPowRef_W, std::clamp(pow_W, 0.0, 1e5)) << pow_W;
    EXPECT_TRUE(out.gensetON);
  }
  // PowerFiltSoc adds gain x (soc_ref - SOC)
  ShevEmsParams s = shipped_ems("shev_power_filt_soc_sort1.toml");
  ASSERT_EQ(s.soc_gain_W, 5e5);
  ASSERT_EQ(s.soc_ref, 0.5);
  ShevEms soc(s, 0.01);
  in.batSOC = 0.45;
  soc.update(in, out);
  EXPECT_NEAR(out.gensetPowRef_W, 20000.0 + 5e5 * 0.05, 1e-9);
}

// ShevEMS: on above 60 kW, off below 30 kW, each at the first sample beyond its threshold, never
// inside the band however the input jitters.
TEST(ShevEms, TheGensetStartsAbove60kWAndStopsBelow30kWAtTheFirstSampleBeyond) {
  ShevEmsParams p = shipped_ems("shev_oo_sort1.toml");
  ASSERT_EQ(p.on_W, 60000.0);
  ASSERT_EQ(p.off_W, 30000.0);
  p.soc_gain_W = 0.0;
  p.power_filter_s = 1e-9;
  ShevEms ems(p, 0.01);
  msgs::ShevSensors in;
  msgs::ShevCommand out;
  std::vector<std::pair<int, bool>> switches;
  bool on = false;
  double before_W = 0.0;
  // a triangle 0 -> 100 kW -> 0 with +-10 kW of jitter
  for (int k = 0; k < 20000; ++k) {
    const double base = 10.0 * (k < 10000 ? k : 20000 - k);
    in.drivePowDc_W = base + 10000.0 * std::sin(0.7 * k);
    ems.update(in, out);
    const double p_c = ems.power_command_W();
    if (out.gensetON != on) {
      switches.emplace_back(k, out.gensetON);
      // located: beyond the threshold now, not at the sample before
      if (out.gensetON) {
        EXPECT_GT(p_c, 60000.0);
        EXPECT_LE(before_W, 60000.0);
      } else {
        EXPECT_LT(p_c, 30000.0);
        EXPECT_GE(before_W, 30000.0);
      }
      on = out.gensetON;
    }
    EXPECT_EQ(out.gensetPowRef_W, out.gensetON ? p_c : 0.0);
    before_W = p_c;
  }
  ASSERT_EQ(switches.size(), 2u);
  EXPECT_TRUE(switches[0].second);
  EXPECT_FALSE(switches[1].second);
}

// Every signal at every output row of a shipped scenario (test::run_columns), its audit closed
// and no fault: name -> values.
std::map<std::string, std::vector<double>> run_all(const std::string& scenario, const std::vector<std::string>& sets,
                                                   plant::EnergyAudit* audit = nullptr,
                                                   const std::vector<std::string>& faults = {}) {
  test::RunColumns r = test::run_columns(scenario, sets, faults);
  EXPECT_LE(std::abs(r.audit.residual_J), 1e-9 * r.audit.scale_J) << scenario << ": the energy audit closes";
  EXPECT_EQ(r.fault, 0u);
  if (audit != nullptr) *audit = r.audit;
  return std::move(r.y);
}

double max_of(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }
double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

// SHEVpowerFilt on Sort1 (400 s, the library's experiment).
TEST(ShevPowerFiltOnSort1, FollowsTheBusCycleAndTheGensetDeliversTheAveragePower) {
  const auto y = run_all("scenarios/shev_power_filt_sort1.toml", {"output.interval_s=0.01"});
  const auto& t = y.at("time_s");
  ASSERT_EQ(t.size(), 40001u);
  // Sort1 is 519.9 m per 150 s period; the driver (k = 500 N m per m/s) lags the cycle by about
  // 1 m/s in its accelerations and covers 505.8 m, the same in every period
  double ref_m = 0.0;
  for (std::size_t i = 1; i <= 15000; ++i) ref_m += 0.5 * (y.at("speed_ref_m_s")[i] + y.at("speed_ref_m_s")[i - 1]) * 0.01;
  EXPECT_NEAR(ref_m, 519.9, 0.1);
  const double d150 = y.at("distance_m")[15000], d300 = y.at("distance_m")[30000];
  EXPECT_NEAR(d150, 505.76, 0.01);
  EXPECT_NEAR(d300 - d150, d150, 1e-6 * d150) << "every period alike";
  // the drive's peak power: 104.8 kW, at the end of the 40 km/h ramp (m_eff a v + road load; the
  // tutorial's 120 kW is not what the model files give: eta = 1 and k = 500)
  EXPECT_NEAR(max_of(y.at("drive_power_dc_W")), 104790.0, 100.0);
  EXPECT_EQ(max_of(y.at("drive_limit_state")), 1.0);  // power region, never cut: the request stays below the limit
  for (std::size_t i = 0; i < t.size(); ++i) {
    ASSERT_EQ(y.at("drive_torque_Nm")[i], y.at("drive_torque_ref_Nm")[i]) << "t = " << t[i];
  }
  // the genset follows the 500 s average of the drive's power (5.09 kW over a period), starting
  // from the filter's 20 kW: 11.50 kW of engine power at 400 s
  double avg_W = 0.0;
  for (std::size_t i = 0; i < 15000; ++i) avg_W += y.at("drive_power_dc_W")[i] / 15000.0;
  EXPECT_NEAR(avg_W, 5085.0, 5.0);
  EXPECT_NEAR(y.at("ice_power_W").back(), 11498.0, 10.0);
  EXPECT_NEAR(y.at("genset_power_ref_W").back(), y.at("ice_power_W").back(), 1.0) << "the engine delivers the request";
  // the generator gives the request at the engine's best speed for it (800-850 rpm), well inside
  // its 500 N m / 45 kW: the DC power stays below 45 kW and the torque below 500 N m
  EXPECT_GT(min_of(y.at("gen_torque_Nm")), -500.0);
  EXPECT_LT(max_of(y.at("genset_power_dc_W")), 45000.0);
  EXPECT_NEAR(y.at("genset_speed_rad_s").back(), 83.53, 0.01);
  // no SOC loop: the genset's surplus charges the battery (0.5 -> 0.579)
  EXPECT_NEAR(y.at("soc").back(), 0.5793, 1e-4);
  EXPECT_NEAR(y.at("fuel_g").back(), 387.3, 0.1);
}

// The tutorial's text starts the filter at 10 kW, the model file at 20 kW: from 10 kW the engine
// gives about 7 kW at 400 s, the tutorial's figure.
TEST(ShevPowerFiltOnSort1, TheTutorialsFilterStartOf10kWGivesItsAbout7kW) {
  const auto y = run_all("scenarios/shev_power_filt_sort1.toml",
                         {"output.interval_s=100", "vehicle.ecu.power_filter_initial_W=10000"});
  EXPECT_NEAR(y.at("ice_power_W").back(), 7000.0, 500.0);
}

// SHEV_OO: ShevEMS's ON/OFF, located at the ECU's samples, through the runner with the EMS in
// reach (its P_c at each sample).
TEST(ShevOOOnSort1, TheGensetStartsAbove60kWStopsBelow30kWAndNeverPassesItsLimits) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/shev_oo_sort1.toml"));
  const auto& p = sc.plant.get<plant::ShevParams>();
  const plant::ShevPlant plant(p);
  ShevEms ems(sc.ecu.get<ShevEmsParams>(), 0.01);
  using Runner = hil::Runner<plant::ShevPlant, solvers::Rk4<plant::ShevPlant>, ShevEms>;
  const std::int64_t steps = 2000000;
  Runner runner(plant, {.total_steps = steps, .decimation = steps, .columns = {0}, .chunk_steps = 10, .ecu_ratio = 10},
                &ems);
  std::vector<double> on_s, off_s;
  bool on = false;
  double before_W = 0.0, max_dc_W = 0.0, max_mech_W = 0.0, max_tau_Nm = 0.0;
  while (!runner.finished()) {
    runner.run();  // 10 steps: one ECU period, its sample at the start
    runner.clear_rows();
    const double p_c = ems.power_command_W();
    const auto& y = runner.last_outputs();
    const bool now = y.genset_on != 0.0;
    if (now != on) {
      (now ? on_s : off_s).push_back(runner.applied_command().stamp.time_s);  // the ECU sample that switched
      if (now) {
        EXPECT_GT(p_c, 60000.0);
        EXPECT_LE(before_W, 60000.0);
      } else {
        EXPECT_LT(p_c, 30000.0);
        EXPECT_GE(before_W, 30000.0);
      }
      on = now;
    }
    before_W = p_c;
    max_dc_W = std::max(max_dc_W, y.genset_power_dc_W);
    max_mech_W = std::max(max_mech_W, -y.gen_power_mech_W);
    max_tau_Nm = std::max(max_tau_Nm, -y.gen_torque_Nm);
  }
  // three starts (P_c > 60 kW as the SOC falls), each stop 106-107 s later
  ASSERT_EQ(on_s.size(), 3u);
  ASSERT_EQ(off_s.size(), 3u);
  // the samples of the independent re-simulation (tools/resim_shev.py)
  EXPECT_NEAR(on_s[0], 267.31, 1e-6);
  EXPECT_NEAR(off_s[0], 373.25, 1e-6);
  EXPECT_NEAR(on_s[1], 1017.49, 1e-6);
  EXPECT_NEAR(off_s[1], 1124.69, 1e-6);
  EXPECT_NEAR(on_s[2], 1713.93, 1e-6);
  EXPECT_NEAR(off_s[2], 1821.03, 1e-6);
  // P_c asks up to 61 kW; the generator gives at most its 45 kW (the power limit acts), the
  // DC side 45 kW x its efficiency, the torque below 500 N m (the engine runs at 97-113 rad/s)
  EXPECT_NEAR(max_mech_W, 45000.0, 1e-6 * 45000.0);
  EXPECT_LT(max_dc_W, 45000.0);
  EXPECT_LE(max_tau_Nm, 500.0);
  EXPECT_EQ(runner.stats().chattering_steps, 0);
  const plant::EnergyAudit a = plant.audit(runner.initial_state(), runner.state());
  EXPECT_LE(std::abs(a.residual_J), 1e-9 * a.scale_J);
}

// OO against PowerFiltSoc, the comparison (SHEV_OO with socRef 0.58): SHEV_OO ends at
// SOC 0.487, PowerFiltSoc at 0.500, and OO burns 46 % of its fuel, 50 % with each battery's
// stored-energy change counted as fuel (the always-on genset spends most of the run at 3-5 kW,
// far from its efficient region).
TEST(ShevOOOnSort1, BurnsLessFuelThanPowerFiltSocAtEqualFinalSoc) {
  plant::EnergyAudit oo_a, soc_a;
  const auto oo = run_all("scenarios/shev_oo_sort1.toml", {"output.interval_s=100", "vehicle.ecu.soc_ref=0.58"}, &oo_a);
  const auto fs = run_all("scenarios/shev_power_filt_soc_sort1.toml", {"output.interval_s=100"}, &soc_a);
  const double soc_oo = oo.at("soc").back(), soc_fs = fs.at("soc").back();
  EXPECT_NEAR(soc_fs, 0.5003, 1e-4);
  EXPECT_NEAR(soc_oo, 0.4873, 1e-4);
  // The packs differ (100 and 200 cells), so equal SOC is not equal energy: compare fuel with each
  // battery's stored-energy change charged as fuel at a pessimistic 25 % (engine x generator; the
  // genset's best is about 35 %)
  const auto stored_out_J = [](const plant::EnergyAudit& a) {
    for (const auto& [name, value] : a.terms) {
      if (name == "battery_stored_out_J") return value;
    }
    return std::nan("");
  };
  const auto equivalent_g = [&](double fuel_g, const plant::EnergyAudit& a) {
    return fuel_g + 1e3 * stored_out_J(a) / (0.25 * 43e6);
  };
  const double oo_g = equivalent_g(oo.at("fuel_g").back(), oo_a), fs_g = equivalent_g(fs.at("fuel_g").back(), soc_a);
  EXPECT_LT(std::abs(oo_g - oo.at("fuel_g").back()), 100.0) << "the correction is small against the difference";
  EXPECT_LT(oo_g, 0.6 * fs_g);
  EXPECT_NEAR(oo.at("fuel_g").back(), 696.3, 0.1);
  EXPECT_NEAR(fs.at("fuel_g").back(), 1525.8, 0.1);
}

// NEDC asks the 14 t bus for up to 120 km/h. SHEVpowerFilt has no SOC loop: its 500 s average
// lags the extra-urban part and the battery empties at 1122.9 s. SHEV_OO's 100-cell pack takes
// the final braking from 120 km/h (130 kW) plus the genset's 38 kW: 500 A of charge, its cell
// limit, at 1132.8 s. Each run stops there with the fault named (a status that says so); the
// 200-cell SHEVpowerFiltSoc runs the whole cycle.
TEST(ShevOnNedc, TwoBusesStopWithTheirFaultNamedThe200CellOneRunsTheCycle) {
  for (const auto& [scenario, fault, step] :
       {std::tuple{"scenarios/shev_power_filt_nedc.toml", plant::kFaultSocWindow, std::int64_t{1122883}},
        std::tuple{"scenarios/shev_oo_nedc.toml", plant::kFaultCellCurrent, std::int64_t{1132830}}}) {
    test::ExpectFault expect;
    const test::RunColumns r = test::run_columns(scenario, {"output.interval_s=100"});
    EXPECT_EQ(r.fault, static_cast<unsigned>(fault)) << scenario;
    EXPECT_EQ(r.steps, step) << scenario;
  }
  const auto y = run_all("scenarios/shev_power_filt_soc_nedc.toml", {"output.interval_s=8"});
  EXPECT_EQ(y.at("time_s").back(), 1184.0);
  EXPECT_NEAR(y.at("soc").back(), 0.409, 1e-3);
  EXPECT_NEAR(y.at("distance_m").back(), 10508.8, 0.1);
}

// The EMS reads the drive's DC power (the library's drivePow, an electrical power sensor): with
// a lossy drive it is above the mechanical power when motoring and below it when braking. And
// the genset's DC power reaches the bus: the battery gives the drive's power less the genset's.
TEST(Shev, TheEmsReadsTheDrivesDcPowerAndTheGensetFeedsTheBus) {
  const hil::Scenario sc = test::load(
      test::source_path("scenarios/shev_oo_sort1.toml"),
      {"vehicle.drive.loss_model=\"map\"",
       "vehicle.drive.efficiency_map=\"" + test::source_path("data/maps/map_shev_mot_eff.csv") + "\""});
  const plant::ShevPlant plant(sc.plant.get<plant::ShevParams>());
  plant::ShevPlant::State x = plant.initial_state();
  x[plant::ShevPlant::kSpeed] = 8.0;
  x[plant::ShevPlant::kGensetSpeed] = 110.0;
  const plant::ShevPlant::Modes m{plant::Motion::kForward};
  for (const double tau_Nm : {400.0, -400.0}) {
    msgs::ShevCommand u;
    u.driveTauRef_Nm = tau_Nm;
    u.gensetPowRef_W = 30000.0;
    u.gensetON = true;
    msgs::ShevSensors s;
    plant.sense(10.0, x, m, u, s);
    plant::ShevPlant::Outputs y;
    plant.outputs(10.0, x, m, u, y);
    EXPECT_EQ(s.drivePowDc_W, y.drive_power_dc_W);
    EXPECT_NE(y.drive_power_dc_W, y.drive_power_mech_W);
    EXPECT_GT(y.drive_power_dc_W, y.drive_power_mech_W) << "losses are drawn in both directions: " << tau_Nm;
    EXPECT_GT(s.gensetPowDc_W, 10000.0);
    EXPECT_NEAR(y.battery_power_W, y.drive_power_dc_W - y.genset_power_dc_W, 1e-6);
    EXPECT_EQ(s.gensetPowDc_W, y.genset_power_dc_W);
  }
}

// OO_noMaps: SHEV_OO's genset at the library's Level 1: its fuel is exactly 200 g/kWh of the
// engine's work, its DC power 0.85 of the generator's, the engine held near 100 rad/s.
TEST(ShevOONoMapsOnSort1, TheGensetWithoutMapsBurns200gPerKWhAndDelivers85Percent) {
  plant::EnergyAudit a;
  const auto y = run_all("scenarios/shev_oo_nomaps_sort1.toml", {"output.interval_s=0.1"}, &a);
  double work_J = 0.0;
  for (const auto& [name, value] : a.terms) {
    if (name == "engine_work_J") work_J = value;
  }
  ASSERT_GT(work_J, 1e7);
  const double fuel_g = y.at("fuel_g").back();
  EXPECT_NEAR(fuel_g, 200.0 * work_J / 3.6e6, 1e-6 * fuel_g);
  std::size_t generating = 0;
  const auto& t = y.at("time_s");
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double mech_W = -y.at("gen_power_mech_W")[i];
    if (mech_W > 1000.0) {
      ++generating;
      ASSERT_NEAR(y.at("genset_power_dc_W")[i], 0.85 * mech_W, 1e-9 * mech_W) << "t = " << t[i];
      ASSERT_NEAR(y.at("genset_speed_ref_rad_s")[i], 100.0, 1e-12) << "t = " << t[i];
      ASSERT_EQ(y.at("ice_torque_max_Nm")[i], 550.0) << "t = " << t[i];
    }
  }
  EXPECT_GT(generating, 1000u);
  EXPECT_GE(max_of(y.at("genset_on")), 1.0);
}

// The faults of issue 23 that apply to the genset: no_start (the EMS's gensetON held false and
// its request 0: the engine never runs) and derating the generator (its torque bound x gain).
std::map<std::string, std::vector<double>> run_faulted(const char* scenario, const std::vector<std::string>& sets,
                                                       const std::vector<std::string>& faults) {
  return run_all(scenario, sets, nullptr, faults);  // a faulted run has faults_active last
}

TEST(ShevFaults, NoStartKeepsTheGensetOffAndDeratingCutsTheGeneratorsPower) {
  const std::vector<std::string> sets = {"solver.duration_s=600", "output.interval_s=0.1"};
  const auto healthy = run_faulted("scenarios/shev_oo_sort1.toml", sets, {});
  ASSERT_EQ(max_of(healthy.at("genset_on")), 1.0);  // it starts at 267.31 s
  const auto off = run_faulted("scenarios/shev_oo_sort1.toml", sets, {"kind=no_start at_s=0"});
  EXPECT_EQ(max_of(off.at("genset_on")), 0.0);
  EXPECT_EQ(max_of(off.at("genset_power_ref_W")), 0.0);
  EXPECT_EQ(off.at("fuel_g").back(), 0.0);
  EXPECT_LT(off.at("soc").back(), healthy.at("soc").back() - 0.05) << "the battery alone drives the bus";
  // derated to half: the generator's 45 kW limit becomes 22.5 kW (its bound x 0.5 in the power region)
  const auto derated = run_faulted("scenarios/shev_oo_sort1.toml", sets, {"kind=derate target=generator gain=0.5 at_s=0"});
  double mech_W = 0.0;
  for (const double p : derated.at("gen_power_mech_W")) mech_W = std::max(mech_W, -p);
  EXPECT_NEAR(mech_W, 22500.0, 1e-6 * 22500.0);
  EXPECT_LT(derated.at("soc").back(), healthy.at("soc").back());
  EXPECT_EQ(max_of(derated.at("faults_active")), 1.0);
  // the flag named: the same as the default
  const auto named = run_faulted("scenarios/shev_oo_sort1.toml", sets, {"kind=no_start target=gensetON at_s=0"});
  EXPECT_EQ(named.at("soc"), off.at("soc"));
  // a flag of another vehicle is named as such
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/shev_oo_sort1.toml"), sets,
                             {"kind=no_start target=iceTauRef_Nm at_s=0"}, sc, errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("acts on the engine: leave target out"), std::string::npos) << errors[0];
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), sets,
                             {"kind=no_start target=gensetON at_s=0"}, sc, errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors.back().find("this vehicle's engine flag is iceON"), std::string::npos) << errors.back();
}

// A key the EMS's kind would ignore is one error, on its own line, not also an unknown key.
TEST(Shev, AnEmsKeyTheKindIgnoresIsOneError) {
  for (const char* set : {"vehicle.ecu.soc_gain_W=1e5", "vehicle.ecu.soc_ref=0.5", "vehicle.ecu.on_W=6e4"}) {
    Scenario sc;
    std::vector<std::string> errors;
    EXPECT_FALSE(load_scenario(test::source_path("scenarios/shev_power_filt_sort1.toml"), {set}, sc, errors));
    ASSERT_EQ(errors.size(), 1u) << set << ": " << (errors.empty() ? "" : errors[0] + " | " + errors.back());
    EXPECT_EQ(errors[0].find("unknown key"), std::string::npos) << errors[0];
    EXPECT_EQ(errors[0].rfind("--set ", 0), 0u) << "located at the override: " << errors[0];
  }
}

// The GMS (genset.hpp): a negative request is taken as 0 (the Genset's input limiter), and
// GensetOO's GMS clamps P / w to the engine's maximum torque where the plain Genset's does not.
TEST(Genset, TheGmsLimitsItsRequestToTheEnginesTorqueOnlyWhereTheModelDoes) {
  plant::GensetParams p = test::load(test::source_path("scenarios/shev_oo_sort1.toml")).plant.get<plant::ShevParams>().genset;
  ASSERT_TRUE(p.gms_limits_torque);
  const double w = 80.0;  // the engine's maximum torque is 380 N m here; 60 kW / 80 rad/s = 750 N m
  const plant::GensetPoint limited = plant::Genset(p).operate(60000.0, true, w);
  EXPECT_EQ(limited.ice_torque_max_Nm, 380.0);
  EXPECT_EQ(limited.gen_request_Nm, -380.0);
  EXPECT_EQ(limited.gen.torque_Nm, -380.0);
  p.gms_limits_torque = false;
  const plant::GensetPoint plain = plant::Genset(p).operate(60000.0, true, w);
  EXPECT_EQ(plain.gen_request_Nm, -750.0);
  EXPECT_EQ(plain.gen.torque_Nm, -500.0) << "the generator's own 500 N m limit";
  // a request below 0 asks nothing of the generator (it never motors the engine)
  const plant::GensetPoint negative = plant::Genset(p).operate(-20000.0, true, 110.0);
  EXPECT_EQ(negative.gen_request_Nm, 0.0);
  EXPECT_EQ(negative.gen.torque_Nm, 0.0);
  EXPECT_EQ(negative.speed_ref_rad_s, plant::Genset(p).operate(0.0, true, 110.0).speed_ref_rad_s);
}

TEST(Shev, TheVehicleFilesNumbersAreWhatThePlantRunsWith) {
  const hil::Scenario oo = test::load(test::source_path("scenarios/shev_oo_sort1.toml"));
  const auto& p = oo.plant.get<plant::ShevParams>();
  EXPECT_EQ(p.body.mass_kg, 14000.0);
  EXPECT_EQ(p.body.wheel_radius_m, 0.473);
  EXPECT_EQ(p.body.gear_ratio, 10.0);
  EXPECT_EQ(p.road.rolling_coefficient, 0.01);
  EXPECT_EQ(p.road.frontal_area_m2, 6.5);
  EXPECT_EQ(p.road.drag_coefficient, 0.65);
  EXPECT_EQ(p.road.air_density_kg_m3, 1.226);
  EXPECT_EQ(p.driver.gain, 200.0);
  EXPECT_EQ(p.driver.request_max, 2000.0);
  EXPECT_EQ(p.drive.torque_max_Nm, 1000.0);
  EXPECT_EQ(p.drive.power_max_W, 150000.0);
  EXPECT_EQ(p.drive.speed_max_rad_s, 3000.0);
  EXPECT_EQ(p.drive.loss_model, plant::DriveLossModel::kIdeal);
  EXPECT_EQ(p.battery.cell_capacity_Ah, 25.0);
  EXPECT_EQ(*p.battery.cell_current_max_A, 500.0);
  EXPECT_EQ(*p.battery.r0_cell_Ohm, 0.35e-3);
  EXPECT_EQ(p.battery.efficiency, 0.9);
  EXPECT_EQ(*p.battery.cell_current_efficiency_A, 200.0);
  EXPECT_EQ(p.battery.cells_series, 100);
  EXPECT_EQ(p.battery.soc_initial, 0.5);
  EXPECT_EQ(p.genset.gear_ratio, 1.0);
  EXPECT_EQ(p.genset.throttle_per_rad_s, 0.1);
  EXPECT_TRUE(p.genset.gms_limits_torque);
  EXPECT_TRUE(p.genset.ice.on_off);
  EXPECT_EQ(p.genset.ice.inertia_kgm2, 0.5);
  EXPECT_EQ(p.genset.ice.speed_initial_rad_s, 300.0);
  EXPECT_EQ(p.genset.generator.torque_max_Nm, 500.0);
  EXPECT_EQ(p.genset.generator.power_max_W, 45000.0);
  EXPECT_EQ(p.genset.generator.speed_max_rad_s, 300.0);
  EXPECT_EQ(p.genset.generator.inertia_kgm2, 0.25);
  const auto& e = oo.ecu.get<ShevEmsParams>();
  EXPECT_EQ(e.kind, ecu::ShevEmsKind::kShevEms);
  EXPECT_EQ(e.period_s, 0.01);
  EXPECT_EQ(e.power_filter_s, 300.0);
  EXPECT_EQ(e.power_filter_initial_W, 20000.0);
  EXPECT_EQ(e.power_max_W, 200000.0);
  EXPECT_EQ(e.soc_ref, 0.6);
  EXPECT_EQ(e.soc_gain_W, 300000.0);
  EXPECT_EQ(e.on_W, 60000.0);
  EXPECT_EQ(e.off_W, 30000.0);
  // the plain genset's GMS has no torque limit (V3), the 200-cell pack of PowerFiltSoc
  const hil::Scenario fs = test::load(test::source_path("scenarios/shev_power_filt_soc_sort1.toml"));
  EXPECT_FALSE(fs.plant.get<plant::ShevParams>().genset.gms_limits_torque);
  EXPECT_FALSE(fs.plant.get<plant::ShevParams>().genset.ice.on_off);
  EXPECT_EQ(fs.plant.get<plant::ShevParams>().battery.cells_series, 200);
  EXPECT_EQ(fs.ecu.get<ShevEmsParams>().kind, ecu::ShevEmsKind::kPowerFiltSoc);
  EXPECT_EQ(fs.ecu.get<ShevEmsParams>().power_filter_s, 500.0);
  const hil::Scenario nm = test::load(test::source_path("scenarios/shev_oo_nomaps_sort1.toml"));
  const auto& g = nm.plant.get<plant::ShevParams>().genset;
  EXPECT_EQ(g.ice.torque_max_Nm(0.0), 550.0);
  EXPECT_EQ(g.ice.torque_max_Nm(300.0), 550.0);
  EXPECT_EQ(g.ice.sfc_g_kWh(100.0, 100.0), 200.0);
  EXPECT_EQ(g.ice.sfc_g_kWh(500.0, 250.0), 200.0);
  EXPECT_NEAR(g.opti_speed_rpm(50000.0) * 2.0 * std::numbers::pi / 60.0, 100.0, 1e-12);
  EXPECT_EQ(g.ice.speed_initial_rad_s, 100.0);
  EXPECT_EQ(g.generator.loss_model, plant::DriveLossModel::kConstant);
  EXPECT_EQ(g.generator.efficiency, 0.85);
  const hil::Scenario pf = test::load(test::source_path("scenarios/shev_power_filt_sort1.toml"));
  EXPECT_EQ(pf.plant.get<plant::ShevParams>().driver.gain, 500.0);
  EXPECT_EQ(*pf.plant.get<plant::ShevParams>().battery.cell_current_efficiency_A, 100.0);
  EXPECT_EQ(pf.ecu.get<ShevEmsParams>().kind, ecu::ShevEmsKind::kPowerFilt);
  const auto& pfp = pf.plant.get<plant::ShevParams>();
  EXPECT_EQ(pfp.battery.cells_series, 100);
  EXPECT_FALSE(pfp.genset.gms_limits_torque);
  EXPECT_EQ(pfp.genset.ice.speed_initial_rad_s, 300.0);
  EXPECT_EQ(pfp.genset.ice.torque_max_Nm(120.0), 800.0);    // map_shev_ice_max_torque.csv
  EXPECT_EQ(pfp.genset.opti_speed_rpm(40000.0), 1100.0);    // map_shev_ice_opti_speed.csv
  EXPECT_EQ(pfp.genset.generator.loss_model, plant::DriveLossModel::kMap);
  EXPECT_EQ(pfp.genset.generator.efficiency_map(0.0, 0.0), 0.75);  // map_shev_genset_drive_eff.csv
  EXPECT_EQ(pfp.genset.generator.power_max_W, 45000.0);
  const auto& pfe = pf.ecu.get<ShevEmsParams>();
  EXPECT_EQ(pfe.power_filter_s, 500.0);
  EXPECT_EQ(pfe.power_filter_initial_W, 20000.0);
  EXPECT_EQ(pfe.power_max_W, 100000.0);
  EXPECT_EQ(pfe.period_s, 0.01);
  const auto& fse = fs.ecu.get<ShevEmsParams>();
  EXPECT_EQ(fse.soc_ref, 0.5);
  EXPECT_EQ(fse.soc_gain_W, 5e5);
  EXPECT_EQ(fse.power_max_W, 100000.0);
  EXPECT_EQ(fse.power_filter_initial_W, 20000.0);
  EXPECT_EQ(*fs.plant.get<plant::ShevParams>().battery.cell_current_efficiency_A, 200.0);
  EXPECT_EQ(fs.plant.get<plant::ShevParams>().driver.gain, 200.0);
  EXPECT_EQ(pf.solver.duration_s, 400.0);  // the library's stop times
  EXPECT_EQ(oo.solver.duration_s, 2000.0);
}

}  // namespace
}  // namespace ehpt::hil
