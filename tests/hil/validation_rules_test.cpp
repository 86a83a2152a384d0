// SPDX-License-Identifier: BSD-3-Clause
// Every validation rule of plant/ and ecu/ (tools/rule_mutants.py finds them in the sources),
// one case each: a valid shipped parameter set, one field spoiled, and the problem that must
// name it with what it expected. Each case was seen to fail with its rule disabled
// (tools/mutate.sh with the list of tools/rule_mutants.py; docs/validation-rules.md).
//
// The cases call validate() on the parameters directly, not through a scenario file: several
// rules (a pole-pair count, a table's order) are also enforced while the file is read, so a file
// could not show that the plant's own rule holds for an embedding program that builds its
// parameters in code.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/config/config.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "plant/am_drive.hpp"
#include "plant/battery_rig.hpp"
#include "plant/bev_plant.hpp"
#include "plant/detailed_machines.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/ev_machine_plant.hpp"
#include "plant/genset_rig.hpp"
#include "plant/machine_test_rigs.hpp"
#include "plant/psd_plant.hpp"
#include "plant/shev_plant.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using plant::Problems;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// One rule: the field the problem must name, a piece of what it must say, and the spoiling.
template <class P>
struct Rule {
  std::string field;
  std::string says;
  std::function<void(P&)> spoil;
};

std::string listed(const Problems& problems) {
  std::string s;
  for (const auto& q : problems.list()) s += "\n  " + q.field + " = " + q.value + ": " + q.expected;
  return s.empty() ? " (none)" : s;
}

// good passes; each rule's spoiled copy gets a problem naming rule.field that says rule.says.
template <class P, class Validate>
void expect_rules(const P& good, Validate validate, const std::vector<Rule<P>>& rules) {
  Problems none;
  validate(good, none);
  ASSERT_TRUE(none.empty()) << "the base is not valid:" << listed(none);
  for (const Rule<P>& rule : rules) {
    P p = good;
    rule.spoil(p);
    Problems found;
    validate(p, found);
    bool named = false;
    for (const auto& q : found.list()) named = named || (q.field == rule.field && q.expected.find(rule.says) != std::string::npos);
    EXPECT_TRUE(named) << rule.field << ": expected \"" << rule.says << "\"; found:" << listed(found);
  }
}

template <class P>
P shipped(const char* scenario) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_TRUE(load_scenario(test::source_path(std::string("scenarios/") + scenario + ".toml"), {}, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  return sc.plant.get<P>();
}

const auto whole = [](const auto& p, Problems& problems) { plant::validate(p, problems); };
template <class P>
auto at(const char* where) {
  return [where](const P& p, Problems& problems) { plant::validate(p, where, problems); };
}

const char* kPositive = "must be a finite number > 0";
const char* kNonNegative = "must be a finite number >= 0";
const char* kFinite = "must be a finite number";

TEST(ValidationRules, TheBatteryRefusesEachOutOfRangeField) {
  // PSecu2's pack has r0 and a current limit; MBEV's the RC branch
  for (const char* scenario : {"psecu2_nedc", "ev_sort1"}) {
    SCOPED_TRACE(scenario);
    const plant::BatteryRcParams good = scenario[0] == 'p' ? shipped<plant::PsdParams>(scenario).battery
                                                           : shipped<plant::BevParams>(scenario).battery;
    using B = plant::BatteryRcParams;
    std::vector<Rule<B>> rules = {
        {"battery.cell_capacity_Ah", kPositive, [](B& b) { b.cell_capacity_Ah = 0; }},
        {"battery.cell_emf_min_V", kPositive, [](B& b) { b.cell_emf_min_V = -0.5; }},
        {"battery.cell_emf_max_V", kPositive, [](B& b) { b.cell_emf_max_V = kInf; }},
        {"battery.cell_emf_max_V", "must be > cell_emf_min_V", [](B& b) { b.cell_emf_max_V = b.cell_emf_min_V; }},
        {"battery.soc_min", "must be in [0, 1]", [](B& b) { b.soc_min = -0.1; }},
        {"battery.soc_max", "must be in [0, 1]", [](B& b) { b.soc_max = 1.5; }},
        {"battery.soc_max", "must be > soc_min", [](B& b) { b.soc_min = b.soc_max = b.soc_initial; }},
        {"battery.soc_initial", "must be in [", [](B& b) { b.soc_initial = 1.2; }},
        {"battery.cell_current_max_A", kPositive, [](B& b) { b.cell_current_max_A = 0.0; }},
        {"battery.r0_cell_Ohm", kPositive, [](B& b) { b.r0_cell_Ohm = -1e-3; }},
        {"battery.r1_cell_Ohm", kPositive, [](B& b) { b.r1_cell_Ohm = 0.0; }},
        {"battery.c1_cell_F", kPositive, [](B& b) { b.c1_cell_F = kNan; }},
        {"battery.cell_current_efficiency_A", kPositive, [](B& b) { b.cell_current_efficiency_A = 0.0; }},
        {"battery.efficiency", "must be in (0, 1]", [](B& b) { b.efficiency = 0.0; }},
        {"battery.cells_series", "must be >= 1", [](B& b) { b.cells_series = 0; }},
        {"battery.strings_parallel", "must be >= 1", [](B& b) { b.strings_parallel = -2; }},
    };
    if (good.r0_cell_Ohm && good.cell_current_efficiency_A) {
      rules.push_back({"battery.efficiency", "the best the cell resistances allow", [](B& b) { b.efficiency = 1.0; }});
    }
    expect_rules(good, at<B>("battery"), rules);
  }
}

TEST(ValidationRules, TheBodyRoadAndDriverRefuseEachOutOfRangeField) {
  const plant::PsdParams psd = shipped<plant::PsdParams>("psecu2_nedc");
  using V = plant::VehicleBodyParams;
  expect_rules(psd.body, at<V>("vehicle"),
               {{"vehicle.mass_kg", kPositive, [](V& v) { v.mass_kg = 0; }},
                {"vehicle.wheel_radius_m", kPositive, [](V& v) { v.wheel_radius_m = kNan; }},
                {"vehicle.gear_ratio", kPositive, [](V& v) { v.gear_ratio = -3.9; }},
                {"vehicle.speed_initial_m_s", kNonNegative, [](V& v) { v.speed_initial_m_s = -1; }}});

  using R = plant::RoadLoadParams;
  const auto bad_slope = [](R& r) { r.slope_rad = plant::Table1d({0.0, 0.0}, {0.0, 0.0}, plant::Extrapolation::kHold); };
  ASSERT_EQ(psd.road.form, plant::RoadLoadForm::kCoefficients);
  expect_rules(psd.road, at<R>("road"),
               {{"road.rolling_coefficient", kNonNegative, [](R& r) { r.rolling_coefficient = -0.01; }},
                {"road.air_density_kg_m3", kPositive, [](R& r) { r.air_density_kg_m3 = 0; }},
                {"road.frontal_area_m2", kNonNegative, [](R& r) { r.frontal_area_m2 = kNan; }},
                {"road.drag_coefficient", kNonNegative, [](R& r) { r.drag_coefficient = -0.3; }},
                {"road.slope", "axis must be strictly increasing", bad_slope},
                {"road.slope", "angle must be in (-1.5, 1.5) rad", [](R& r) {
                   r.slope_rad = plant::Table1d({0.0, 100.0}, {0.0, 1.6}, plant::Extrapolation::kHold);
                 }}});
  R coast = psd.road;
  coast.form = plant::RoadLoadForm::kCoastDown;
  coast.f0_N = 100, coast.f1_N_s_m = 1, coast.f2_N_s2_m2 = 0.4;
  expect_rules(coast, at<R>("road"),
               {{"road.f0_N", kNonNegative, [](R& r) { r.f0_N = -1; }},
                {"road.f1_N_s_m", kNonNegative, [](R& r) { r.f1_N_s_m = kInf; }},
                {"road.f2_N_s2_m2", kNonNegative, [](R& r) { r.f2_N_s2_m2 = -0.4; }}});

  using D = plant::PropDriverParams;
  expect_rules(psd.driver, at<D>("driver"),
               {{"driver.cycle", "axis must be non-decreasing", [](D& d) {
                   d.cycle_m_s = plant::Table1d({0.0, 10.0, 5.0}, {0.0, 1.0, 0.0}, plant::Extrapolation::kHold);
                 }},
                {"driver.cycle", "speed must be >= 0 and below 200 m/s", [](D& d) {
                   d.cycle_m_s = plant::Table1d({0.0, 10.0}, {0.0, -1.0}, plant::Extrapolation::kHold);
                 }},
                {"driver.gain", kNonNegative, [](D& d) { d.gain = -1; }},
                {"driver.request_max", kPositive, [](D& d) { d.request_max = 0; }},
                {"driver.request_min", "must be <= 0", [](D& d) { d.request_min = 0.5; }}});
}

TEST(ValidationRules, TheMapDriveAndTheEngineRefuseEachOutOfRangeField) {
  const plant::PsdParams psd = shipped<plant::PsdParams>("psecu2_nedc");
  using M = plant::MapDriveParams;
  const auto eta = [](double value) {
    return plant::Table2d({0.0, 100.0}, {0.0, 100.0}, {0.9, 0.9, 0.9, value});
  };
  ASSERT_EQ(psd.mot.loss_model, plant::DriveLossModel::kMap);
  expect_rules(psd.mot, at<M>("mot"),
               {{"mot.torque_max_Nm", kPositive, [](M& m) { m.torque_max_Nm = 0; }},
                {"mot.power_max_W", kPositive, [](M& m) { m.power_max_W = -1; }},
                {"mot.speed_max_rad_s", kPositive, [](M& m) { m.speed_max_rad_s = kNan; }},
                {"mot.inertia_kgm2", kPositive, [](M& m) { m.inertia_kgm2 = 0; }},
                {"mot.limit_ramp_fraction", "must be in (0, 1]", [](M& m) { m.limit_ramp_fraction = 0; }},
                {"mot.efficiency_map", "must be a finite number", [&](M& m) { m.efficiency_map = eta(kNan); }},
                {"mot.efficiency_map", "efficiency must be in (0, 1]", [&](M& m) { m.efficiency_map = eta(1.2); }}});
  M formula = psd.mot;
  formula.loss_model = plant::DriveLossModel::kFormula;
  expect_rules(formula, at<M>("mot"),
               {{"mot.loss_formula.a", kNonNegative, [](M& m) { m.loss_formula.a = -1; }},
                {"mot.loss_formula.b_t", kNonNegative, [](M& m) { m.loss_formula.b_t = -1; }},
                {"mot.loss_formula.b_w", kNonNegative, [](M& m) { m.loss_formula.b_w = kNan; }},
                {"mot.loss_formula.b_p", kNonNegative, [](M& m) { m.loss_formula.b_p = -1; }}});

  using I = plant::MapIceParams;
  const auto curve = [](double y1) { return plant::Table1d({0.0, 100.0}, {50.0, y1}, plant::Extrapolation::kHold); };
  const auto sfc = [](double v) { return plant::Table2d({0.0, 100.0}, {0.0, 100.0}, {250, 250, 250, v}); };
  expect_rules(psd.ice, at<I>("ice"),
               {{"ice.inertia_kgm2", kPositive, [](I& i) { i.inertia_kgm2 = 0; }},
                {"ice.speed_initial_rad_s", kFinite, [](I& i) { i.speed_initial_rad_s = kNan; }},
                {"ice.control_gain_Nm_W", kNonNegative, [](I& i) { i.control_gain_Nm_W = -0.1; }},
                {"ice.fuel_lhv_J_kg", kPositive, [](I& i) { i.fuel_lhv_J_kg = 0; }},
                {"ice.fuel_density_kg_m3", kPositive, [](I& i) { i.fuel_density_kg_m3 = kInf; }},
                {"ice.torque_max", "must be a finite number", [&](I& i) { i.torque_max_Nm = curve(kNan); }},
                {"ice.torque_max", "maximum torque must be >= 0", [&](I& i) { i.torque_max_Nm = curve(-1); }},
                {"ice.sfc_map", "must be a finite number", [&](I& i) { i.sfc_g_kWh = sfc(kInf); }},
                {"ice.sfc_map", "specific consumption must be > 0", [&](I& i) { i.sfc_g_kWh = sfc(0); }}});
}

TEST(ValidationRules, TheMachineDrivesRefuseEachOutOfRangeField) {
  using Pm = plant::PmDriveParams;
  expect_rules(shipped<plant::EvPmParams>("evpm_sort1").drive, at<Pm>("drive"),
               {{"drive.pole_pairs", "must be a whole number in [1, 100]", [](Pm& m) { m.pole_pairs = 0; }},
                {"drive.psi_pm_Wb", kPositive, [](Pm& m) { m.psi_pm_Wb = 0; }},
                {"drive.Ld_H", kPositive, [](Pm& m) { m.Ld_H = -1; }},
                {"drive.Lq_H", kPositive, [](Pm& m) { m.Lq_H = kNan; }},
                {"drive.U_max_rms_V", kPositive, [](Pm& m) { m.U_max_rms_V = 0; }},
                {"drive.I_lim_rms_A", kPositive, [](Pm& m) { m.I_lim_rms_A = 0; }},
                {"drive.Rs_Ohm", kNonNegative, [](Pm& m) { m.Rs_Ohm = -0.01; }},
                {"drive.k_inv_W_per_A", kNonNegative, [](Pm& m) { m.k_inv_W_per_A = kNan; }},
                {"drive.inertia_kgm2", kPositive, [](Pm& m) { m.inertia_kgm2 = 0; }},
                {"drive.speed_max_rad_s", kPositive, [](Pm& m) { m.speed_max_rad_s = -1; }},
                {"drive.I_lim_rms_A", "is below the no-load current", [](Pm& m) { m.I_lim_rms_A = 1e-3; }}});

  using Am = plant::AmDriveParams;
  expect_rules(shipped<plant::EvAmParams>("evam_sort1").drive, at<Am>("drive"),
               {{"drive.pole_pairs", "must be a whole number in [1, 100]", [](Am& m) { m.pole_pairs = 101; }},
                {"drive.R1_Ohm", kPositive, [](Am& m) { m.R1_Ohm = 0; }},
                {"drive.R2_Ohm", kPositive, [](Am& m) { m.R2_Ohm = -1; }},
                {"drive.L1_H", kPositive, [](Am& m) { m.L1_H = 0; }},
                {"drive.L2_H", kPositive, [](Am& m) { m.L2_H = kNan; }},
                {"drive.Lm_H", kPositive, [](Am& m) { m.Lm_H = 0; }},
                {"drive.U_base_rms_V", kPositive, [](Am& m) { m.U_base_rms_V = 0; }},
                {"drive.w_e_base_rad_s", kPositive, [](Am& m) { m.w_e_base_rad_s = -1; }},
                {"drive.I_max_rms_A", kPositive, [](Am& m) { m.I_max_rms_A = 0; }},
                {"drive.inertia_kgm2", kNonNegative, [](Am& m) { m.inertia_kgm2 = -0.1; }},
                {"drive.k_inv_W_per_A", kNonNegative, [](Am& m) { m.k_inv_W_per_A = -1; }},
                {"drive.I_max_rms_A", "must be above the no-load (magnetising) current",
                 [](Am& m) { m.I_max_rms_A = 1.0; }}});

  using Pu = plant::AmDrivePuParams;
  expect_rules(Pu{}, at<Pu>("drive"),
               {{"drive.pole_pairs", "must be a whole number in [1, 100]", [](Pu& m) { m.pole_pairs = 0; }},
                {"drive.S_nom_VA", kPositive, [](Pu& m) { m.S_nom_VA = 0; }},
                {"drive.V_nom_rms_V", kPositive, [](Pu& m) { m.V_nom_rms_V = -1; }},
                {"drive.f_nom_Hz", kPositive, [](Pu& m) { m.f_nom_Hz = 0; }},
                {"drive.r1_pu", kPositive, [](Pu& m) { m.r1_pu = 0; }},
                {"drive.r2_pu", kPositive, [](Pu& m) { m.r2_pu = kNan; }},
                {"drive.x1_pu", kPositive, [](Pu& m) { m.x1_pu = 0; }},
                {"drive.x2_pu", kPositive, [](Pu& m) { m.x2_pu = -1; }},
                {"drive.xm_pu", kPositive, [](Pu& m) { m.xm_pu = 0; }},
                {"drive.I_max_pu", kPositive, [](Pu& m) { m.I_max_pu = 0; }},
                {"drive.H_s", kNonNegative, [](Pu& m) { m.H_s = -1; }},
                {"drive.k_inv_pu", kNonNegative, [](Pu& m) { m.k_inv_pu = kNan; }},
                {"drive.I_max_pu", "must be above the no-load (magnetising) current", [](Pu& m) { m.I_max_pu = 0.3; }}});

  using S = plant::PmsmParams;
  expect_rules(S{}, at<S>("machine"),
               {{"machine.pole_pairs", "must be a whole number in [1, 100]", [](S& m) { m.pole_pairs = 0; }},
                {"machine.psi_pm_Wb", kPositive, [](S& m) { m.psi_pm_Wb = 0; }},
                {"machine.Ld_H", kPositive, [](S& m) { m.Ld_H = -1; }},
                {"machine.Lq_H", kPositive, [](S& m) { m.Lq_H = kNan; }},
                {"machine.Rs_Ohm", kNonNegative, [](S& m) { m.Rs_Ohm = -0.01; }},
                {"machine.current_filter_s", kPositive, [](S& m) { m.current_filter_s = 0; }}});
  using Im = plant::InductionMachineParams;
  expect_rules(Im{}, at<Im>("machine"),
               {{"machine.pole_pairs", "must be a whole number in [1, 100]", [](Im& m) { m.pole_pairs = 200; }},
                {"machine.R1_Ohm", kNonNegative, [](Im& m) { m.R1_Ohm = -1; }},
                {"machine.R2_Ohm", kPositive, [](Im& m) { m.R2_Ohm = 0; }},
                {"machine.L1_H", kPositive, [](Im& m) { m.L1_H = 0; }},
                {"machine.L2_H", kPositive, [](Im& m) { m.L2_H = kNan; }},
                {"machine.Lm_H", kPositive, [](Im& m) { m.Lm_H = -1; }}});
}

TEST(ValidationRules, TheRigsRefuseEachOutOfRangeField) {
  using T = plant::Trapezoid;
  expect_rules(T{0, 1, 0, 1, 1, 1, 10}, at<T>("request"),
               {{"request.offset", kFinite, [](T& t) { t.offset = kNan; }},
                {"request.amplitude", kFinite, [](T& t) { t.amplitude = kInf; }},
                {"request.start_s", kNonNegative, [](T& t) { t.start_s = -1; }},
                {"request.rising_s", kPositive, [](T& t) { t.rising_s = 0; }},
                {"request.width_s", kNonNegative, [](T& t) { t.width_s = -1; }},
                {"request.falling_s", kPositive, [](T& t) { t.falling_s = 0; }},
                {"request.period_s", "must be >= rising_s + width_s + falling_s", [](T& t) { t.period_s = 2.5; }}});

  using Rig = plant::DriveRigParams;
  expect_rules(shipped<Rig>("one_flange_test"), whole,
               {{"drive.torque_max_Nm", kPositive, [](Rig& r) { r.drive.torque_max_Nm = 0; }},
                {"load.inertia_kgm2", kNonNegative, [](Rig& r) { r.load_inertia_kgm2 = -1; }},
                {"load.speed_initial_rad_s", kFinite, [](Rig& r) { r.speed_initial_rad_s = kNan; }},
                {"load.torque_nominal_Nm", kFinite, [](Rig& r) { r.load_torque_nominal_Nm = kInf; }},
                {"load.speed_nominal_rad_s", kPositive, [](Rig& r) { r.load_speed_nominal_rad_s = 0; }},
                {"load.flange_a_torque_Nm", kFinite, [](Rig& r) { r.flange_a_torque_Nm = kNan; }},
                {"dc_voltage_V", kPositive, [](Rig& r) { r.dc_voltage_V = 0; }},
                {"request.rising_s", kPositive, [](Rig& r) { r.request_Nm.rising_s = 0; }}});

  using Pt = plant::PmDriveTestParams;
  expect_rules(shipped<Pt>("test_pm_drive"), whole,
               {{"machine.psi_pm_Wb", kPositive, [](Pt& r) { r.machine.psi_pm_Wb = 0; }},
                {"u_dc_V", kPositive, [](Pt& r) { r.u_dc_V = 0; }},
                {"current_filter_s", kPositive, [](Pt& r) { r.current_filter_s = kNan; }},
                {"speed.rising_s", kPositive, [](Pt& r) { r.speed_rad_s.rising_s = 0; }},
                {"speed.offset_rad_s", kFinite, [](Pt& r) { r.speed_rad_s.offset = kNan; }},
                {"request.amplitude_Nm", kFinite, [](Pt& r) { r.request_Nm.amplitude = kInf; }},
                {"speed.amplitude_rad_s", "beyond machine.speed_max_rad_s",
                 [](Pt& r) { r.speed_rad_s.amplitude = 2 * r.machine.speed_max_rad_s; }}});

  using At = plant::AmDriveTestParams;
  expect_rules(shipped<At>("test_am_drive"), whole,
               {{"machine.R1_Ohm", kPositive, [](At& r) { r.machine.R1_Ohm = 0; }},
                {"speed.width_s", kNonNegative, [](At& r) { r.speed_rad_s.width_s = -1; }},
                {"request.falling_s", kPositive, [](At& r) { r.request_Nm.falling_s = 0; }}});

  using Br = plant::BatteryRigParams;
  expect_rules(shipped<Br>("battery_cc_discharge"), whole,
               {{"battery.cell_capacity_Ah", kPositive, [](Br& r) { r.battery.cell_capacity_Ah = 0; }},
                {"profile", "must have at least one segment", [](Br& r) { r.profile.clear(); }},
                {"profile[0].current_A", kFinite, [](Br& r) {
                   r.profile[0] = {plant::BatterySegment::Kind::kCurrent, kNan, 10.0};
                 }},
                {"profile[0].power_W", kFinite, [](Br& r) {
                   r.profile[0] = {plant::BatterySegment::Kind::kPower, kInf, 10.0};
                 }},
                {"profile[0].duration_s", kPositive, [](Br& r) { r.profile[0].duration_s = 0; }}});

  using Gr = plant::GensetRigParams;
  const auto opti = [](std::vector<double> x, std::vector<double> y) {
    return plant::Table1d(std::move(x), std::move(y), plant::Extrapolation::kHold);
  };
  expect_rules(shipped<Gr>("genset_test_oo"), whole,
               {{"genset.ice.inertia_kgm2", kPositive, [](Gr& r) { r.genset.ice.inertia_kgm2 = 0; }},
                {"genset.ice.torque_max", "needs at least 2 rows", [](Gr& r) { r.genset.ice.torque_max_Nm = {}; }},
                {"genset.generator.power_max_W", kPositive, [](Gr& r) { r.genset.generator.power_max_W = 0; }},
                {"genset.gear_ratio", kPositive, [](Gr& r) { r.genset.gear_ratio = 0; }},
                {"genset.throttle_per_rad_s", kPositive, [](Gr& r) { r.genset.throttle_per_rad_s = kNan; }},
                {"genset.opti_speed", "strictly increasing",
                 [&](Gr& r) { r.genset.opti_speed_rpm = opti({0, 0}, {800, 850}); }},
                {"genset.opti_speed", "must be > 0 rpm", [&](Gr& r) { r.genset.opti_speed_rpm = opti({0, 1e4}, {800, 0}); }},
                {"request.rising_s", kPositive, [](Gr& r) { r.request_W.rising_s = 0; }},
                {"off_at_s", "must be >= 0 s", [](Gr& r) { r.off_at_s = -1; }},
                {"off_at_s", "must be >= 0 s", [](Gr& r) { r.off_at_s = kNan; }},
                {"dc_voltage_V", kPositive, [](Gr& r) { r.dc_voltage_V = 0; }}});
}

// Each vehicle checks each of its components (a spoiled field in each names it) and its own
// cross-component rules.
TEST(ValidationRules, EachVehicleChecksEachComponentAndItsOwnRules) {
  using Psd = plant::PsdParams;
  expect_rules(shipped<Psd>("psecu2_nedc"), whole,
               {{"vehicle.mass_kg", kPositive, [](Psd& p) { p.body.mass_kg = 0; }},
                {"road.air_density_kg_m3", kPositive, [](Psd& p) { p.road.air_density_kg_m3 = 0; }},
                {"driver.request_max", kPositive, [](Psd& p) { p.driver.request_max = 0; }},
                {"battery.cell_capacity_Ah", kPositive, [](Psd& p) { p.battery.cell_capacity_Ah = 0; }},
                {"ice.inertia_kgm2", kPositive, [](Psd& p) { p.ice.inertia_kgm2 = 0; }},
                {"gen.torque_max_Nm", kPositive, [](Psd& p) { p.gen.torque_max_Nm = 0; }},
                {"mot.torque_max_Nm", kPositive, [](Psd& p) { p.mot.torque_max_Nm = 0; }},
                {"planetary.ring_sun_ratio", "must be > 1", [](Psd& p) { p.ring_sun_ratio = 1.0; }},
                {"brake.after_rotor_inertia", "only the map-based EV", [](Psd& p) { p.brake.after_rotor_inertia = true; }}});

  using Shev = plant::ShevParams;
  expect_rules(shipped<Shev>("shev_oo_sort1"), whole,
               {{"vehicle.wheel_radius_m", kPositive, [](Shev& p) { p.body.wheel_radius_m = 0; }},
                {"road.rolling_coefficient", kNonNegative, [](Shev& p) { p.road.rolling_coefficient = -1; }},
                {"driver.request_max", kPositive, [](Shev& p) { p.driver.request_max = kNan; }},
                {"battery.cells_series", "must be >= 1", [](Shev& p) { p.battery.cells_series = 0; }},
                {"drive.speed_max_rad_s", kPositive, [](Shev& p) { p.drive.speed_max_rad_s = 0; }},
                {"genset.generator.torque_max_Nm", kPositive, [](Shev& p) { p.genset.generator.torque_max_Nm = 0; }},
                {"brake.after_rotor_inertia", "only the map-based EV", [](Shev& p) { p.brake.after_rotor_inertia = true; }},
                {"genset.ice.input", "IceT01, run by its GMS through the throttle",
                 [](Shev& p) { p.genset.ice.input = plant::IceInput::kPower; }}});
  // OO_noMaps: the generator's one efficiency
  expect_rules(shipped<Shev>("shev_oo_nomaps_sort1"), whole,
               {{"genset.generator.efficiency", "must be in (0, 1]", [](Shev& p) { p.genset.generator.efficiency = 0; }},
                {"genset.generator.efficiency", "must be in (0, 1]", [](Shev& p) { p.genset.generator.efficiency = 1.01; }},
                {"genset.generator.efficiency", "must be in (0, 1]", [](Shev& p) { p.genset.generator.efficiency = kNan; }}});

  using Bev = plant::BevParams;
  expect_rules(shipped<Bev>("ev_sort1"), whole,
               {{"vehicle.gear_ratio", kPositive, [](Bev& p) { p.body.gear_ratio = 0; }},
                {"road.frontal_area_m2", kNonNegative, [](Bev& p) { p.road.frontal_area_m2 = -1; }},
                {"drive.power_max_W", kPositive, [](Bev& p) { p.drive.power_max_W = 0; }},
                {"battery.soc_initial", "must be in [", [](Bev& p) { p.battery.soc_initial = 2; }},
                {"driver.gain", kNonNegative, [](Bev& p) { p.driver.gain = -1; }},
                {"brake.after_rotor_inertia", "must be below vehicle.mass_kg", [](Bev& p) {
                   p.brake.enabled = true;
                   p.brake.after_rotor_inertia = true;
                   p.drive.inertia_kgm2 = 1e4;
                 }}});

  using Pm = plant::EvPmParams;
  expect_rules(shipped<Pm>("evpm_sort1"), whole,
               {{"drive.Ld_H", kPositive, [](Pm& p) { p.drive.Ld_H = 0; }},
                {"brake.after_rotor_inertia", "is MBEV's brake signal", [](Pm& p) { p.brake.after_rotor_inertia = true; }},
                {"drive.U_max_rms_V", "the DC bus cannot supply it", [](Pm& p) { p.drive.U_max_rms_V = 1e4; }}});
  using Am = plant::EvAmParams;
  expect_rules(shipped<Am>("evam_sort1"), whole,
               {{"drive.Lm_H", kPositive, [](Am& p) { p.drive.Lm_H = 0; }},
                {"drive.U_base_rms_V", "the DC bus cannot supply it", [](Am& p) { p.drive.U_base_rms_V = 1e4; }}});
}

TEST(ValidationRules, ThePowerSplitEcuRefusesEachOutOfRangeField) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {}, sc, errors));
  using E = ecu::PsdEcuParams;
  const auto check = [](const E& p, Problems& problems) { ecu::validate(p, "ecu", problems); };
  expect_rules(sc.ecu.get<E>(), check,
               {{"ecu.max_torque_request_Nm", kPositive, [](E& e) { e.max_torque_request_Nm = 0; }},
                {"ecu.power_filter_s", kPositive, [](E& e) { e.power_filter_s = 0; }},
                {"ecu.gen_loop_gain_Nm_s_rad", kNonNegative, [](E& e) { e.gen_loop_gain_Nm_s_rad = -1; }},
                {"ecu.gen_filter_s", kPositive, [](E& e) { e.gen_filter_s = kNan; }},
                {"ecu.gen_torque_max_Nm", kPositive, [](E& e) { e.gen_torque_max_Nm = 0; }},
                {"ecu.ice_speed_min_rad_s", kNonNegative, [](E& e) { e.ice_speed_min_rad_s = -1; }},
                {"ecu.power_to_speed", "axis must be strictly increasing", [](E& e) {
                   e.power_to_speed_rad_s = plant::Table1d({0.0, 0.0}, {100.0, 200.0}, plant::Extrapolation::kHold);
                 }},
                {"ecu.soc_ref", "must be in [0, 1]", [](E& e) { e.soc_ref = 1.5; }},
                {"ecu.soc_loop_gain_W", kNonNegative, [](E& e) { e.soc_loop_gain_W = -1; }},
                {"ecu.on_threshold_W", kFinite, [](E& e) { e.on_threshold_W = kInf; }},
                {"ecu.off_threshold_W", kFinite, [](E& e) { e.off_threshold_W = -kInf; }},
                {"ecu.off_threshold_W", "(hysteresis)", [](E& e) { e.off_threshold_W = e.on_threshold_W; }},
                {"ecu.ice_off_speed_ref_rad_s", kNonNegative, [](E& e) { e.ice_off_speed_ref_rad_s = -1; }}});
}

TEST(ValidationRules, TheSeriesHybridEmsRefusesEachOutOfRangeField) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/shev_oo_sort1.toml"), {}, sc, errors));
  using E = ecu::ShevEmsParams;
  const auto check = [](const E& p, Problems& problems) { ecu::validate(p, "ecu", problems); };
  expect_rules(sc.ecu.get<E>(), check,
               {{"ecu.power_filter_s", kPositive, [](E& e) { e.power_filter_s = 0; }},
                {"ecu.power_filter_initial_W", kFinite, [](E& e) { e.power_filter_initial_W = kNan; }},
                {"ecu.soc_ref", "must be in [0, 1]", [](E& e) { e.soc_ref = -0.1; }},
                {"ecu.soc_gain_W", kNonNegative, [](E& e) { e.soc_gain_W = -1; }},
                {"ecu.power_max_W", kPositive, [](E& e) { e.power_max_W = 0; }},
                {"ecu.on_W", kFinite, [](E& e) { e.on_W = kInf; }},
                {"ecu.off_W", kFinite, [](E& e) { e.off_W = kNan; }},
                {"ecu.off_W", "(hysteresis)", [](E& e) { e.off_W = e.on_W; }},
                {"ecu.on_W", "the genset would never start", [](E& e) { e.on_W = e.power_max_W; }},
                {"ecu.off_W", "the genset would never stop", [](E& e) { e.off_W = 0; }}});
  // PowerFilt and PowerFiltSoc have no ON/OFF: their thresholds are not checked
  E filt = sc.ecu.get<E>();
  filt.kind = ecu::ShevEmsKind::kPowerFiltSoc;
  filt.off_W = filt.on_W = kNan;
  Problems none;
  ecu::validate(filt, "ecu", none);
  EXPECT_TRUE(none.empty()) << listed(none);
}

TEST(ValidationRules, ATableIsSortedFiniteAndLongEnough) {
  using plant::Extrapolation;
  using plant::Table1d;
  const auto curve = [](bool repeats) {
    return [repeats](const Table1d& t, Problems& problems) { plant::validate(t, "t", repeats, problems); };
  };
  expect_rules(Table1d({0, 1, 2}, {0, 1, 0}, Extrapolation::kHold), curve(false),
               {{"t", "needs at least 2 rows", [](Table1d& t) { t = Table1d({0}, {0}, Extrapolation::kHold); }},
                {"t", "must be a finite number", [](Table1d& t) { t = Table1d({0, 1}, {0, kNan}, Extrapolation::kHold); }},
                {"t", "axis must be strictly increasing", [](Table1d& t) {
                   t = Table1d({0, 1, 1}, {0, 0, 0}, Extrapolation::kHold);
                 }}});
  expect_rules(Table1d({0, 1, 1}, {0, 1, 0}, Extrapolation::kHold), curve(true),
               {{"t", "axis must be non-decreasing", [](Table1d& t) { t = Table1d({0, 1, 0.5}, {0, 0, 0}, Extrapolation::kHold); }},
                {"t", "axis must span a non-zero range", [](Table1d& t) { t = Table1d({1, 1}, {0, 0}, Extrapolation::kHold); }}});

  using plant::Table2d;
  const auto map = [](const Table2d& t, Problems& problems) { plant::validate(t, "m", problems); };
  expect_rules(Table2d({0, 1}, {0, 1}, {1, 2, 3, 4}), map,
               {{"m", "a map needs at least 2 values on each axis", [](Table2d& t) { t = Table2d({0}, {0, 1}, {1, 2}); }},
                {"m", "column axis must be finite and strictly increasing", [](Table2d& t) {
                   t = Table2d({0, 1}, {1, 0}, {1, 2, 3, 4});
                 }},
                {"m", "grid needs 4 values", [](Table2d& t) { t = Table2d({0, 1}, {0, 1}, {1, 2, 3}); }},
                {"m", "must be a finite number", [](Table2d& t) { t = Table2d({0, 1}, {0, 1}, {1, 2, kNan, 4}); }}});
}

}  // namespace
}  // namespace ehpt::hil

// ---- the readers' rules (hil/config/, hil/kinds/): each message as the user sees it ---------
// Each case was seen to fail with its rule disabled (tools/rule_mutants.py list config).

namespace ehpt::hil {
namespace {

namespace fs = std::filesystem;

struct ReaderCase {
  std::string scenario;           // a shipped scenario's name, or a path
  std::vector<std::string> sets;  // --set overrides
  std::string says;               // a piece of the error (or warning) it must give
  bool warning = false;
};

fs::path scratch_dir(const std::string& name) {
  const fs::path d = test::scratch_root() / ("ehpt_reader_rules_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string text_of(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += "\n  " + l;
  return s.empty() ? " (none)" : s;
}

void expect_reader_rule(const ReaderCase& c) {
  const std::string path =
      c.scenario.find('/') == std::string::npos ? test::source_path("scenarios/" + c.scenario + ".toml") : c.scenario;
  Scenario sc;
  std::vector<std::string> errors;
  const bool ok = load_scenario(path, c.sets, sc, errors);
  const std::vector<std::string>& said = c.warning ? sc.warnings : errors;
  const bool found = std::any_of(said.begin(), said.end(), [&](const std::string& e) { return e.find(c.says) != std::string::npos; });
  EXPECT_TRUE(found) << c.scenario << " " << (c.sets.empty() ? "" : c.sets.back()) << ": expected \"" << c.says
                     << "\"; errors:" << text_of(errors) << "\nwarnings:" << text_of(sc.warnings);
  if (!c.warning) {
    EXPECT_FALSE(ok) << c.says;
  }
}

TEST(ReaderRules, EachValueOfTheWrongKindIsNamed) {
  for (const ReaderCase& c : std::vector<ReaderCase>{
           {"ev_sort1", {"vehicle=\"\""}, "vehicle = '': must be the name of a shipped vehicle (a non-empty string"},
           {"ev_sort1", {"vehicle=5"}, "vehicle = 5: must be a shipped vehicle's name (vehicle = \"psecu2\") or a table"},
           {"ev_sort1", {"solver.duration_s=-1"}, "must be a finite number > 0 s (give it, or a cycle whose last time stamp"},
           {"ev_sort1", {"vehicle.drive.loss_model=\"magic\""}, "\"magic\": must be \"ideal\", \"map\", \"formula\" or \"constant\""},
           {"ev_sort1", {"vehicle.road.form=\"flat\""}, "\"flat\": must be \"coefficients\" or \"coast-down\""},
           {"psecu2_nedc", {"vehicle.ice.input=\"fuel\""}, "\"fuel\": must be \"power\" or \"torque\""},
           {"ev_sort1", {"output.decimation=1.5"}, "output.decimation = 1.5: must be a whole number"},
           {"ev_sort1", {"output.timeseries=1"}, "output.timeseries = 1: must be true or false"},
           {"ev_sort1", {"solver.method=5"}, "solver.method = 5: must be a string"},
           {"ev_sort1", {"output.signals=5"}, "output.signals = 5: must be an array of strings"},
           {"ev_sort1", {"output.signals=[1]"}, "must be a string"},
           {"ev_sort1", {"output.signals=[\"speed_m_s\", \"warp\"]"}, "unknown signal; available"},
           {"psecu2_nedc", {"vehicle.ice.sfc_map=\"\""}, "must be a file name (a non-empty string)"},
           {"battery_cc_discharge", {"vehicle.profile=5"}, "must be an array of tables ([["},
           {"battery_cc_discharge", {"vehicle.profile=[1]"}, "must be a table"},
           {"ev_sort1", {"vehicle.battery=5"}, "must be a table"},
           {"ev_sort1", {"vehicle.battery.capacity_of_the_pack=5"}, "unknown key"},
           {"ev_sort1", {"vehicle.ecu.kind=\"MBecu2\""}, "must be \"follower\" (the built-in ECU of the EV"},
           {"psecu2_nedc", {"vehicle.ecu.kind=\"follower\""}, "must be \"MBecu1\", \"MBecu1soc\" or \"MBecu2\""},
           {"shev_oo_sort1", {"vehicle.ecu.kind=\"MBecu2\""}, "must be \"PowerFilt\", \"PowerFiltSoc\" or \"ShevEMS\""},
           {"shev_power_filt_sort1", {"vehicle.ecu.soc_gain_W=1e5"}, "PowerFilt has no SOC loop: use kind = \"PowerFiltSoc\""},
           {"shev_power_filt_soc_sort1", {"vehicle.ecu.on_W=6e4"}, "only ShevEMS switches the genset on and off"},
           {"shev_power_filt_soc_sort1", {"vehicle.ecu.off_W=3e4"}, "only ShevEMS switches the genset on and off"},
           {"shev_oo_sort1", {"vehicle.genset.ice.on_off=false"}, "ShevEMS switches the genset off through gensetON", true},
           {"shev_oo_nomaps_sort1", {"vehicle.genset.ice.sfc_map=\"" + test::source_path("data/maps/map_shev_ice_sfc.csv") + "\""},
            "give either sfc_map or sfc_g_kWh, not both"},
           {"shev_oo_nomaps_sort1",
            {"vehicle.genset.ice.torque_max_table=\"" + test::source_path("data/maps/map_shev_ice_max_torque.csv") + "\""},
            "give either torque_max_table or torque_max_Nm, not both"},
           {"shev_oo_nomaps_sort1",
            {"vehicle.genset.opti_speed_table=\"" + test::source_path("data/maps/map_shev_ice_opti_speed.csv") + "\""},
            "give either opti_speed_table or opti_speed_rad_s, not both"},
           {"shev_power_filt_sort1", {"vehicle.ecu.soc_ref=0.5"}, "PowerFilt has no SOC loop: use kind = \"PowerFiltSoc\""},
           {"shev_oo_nomaps_sort1", {"vehicle.genset.ice.torque_max_Nm=0"}, "torque_max_Nm = 0: must be a finite number > 0"},
           {"shev_oo_nomaps_sort1", {"vehicle.genset.ice.sfc_g_kWh=-1"}, "sfc_g_kWh = -1: must be a finite number > 0"},
           {"shev_oo_nomaps_sort1", {"vehicle.genset.opti_speed_rad_s=-10"}, "opti_speed_rad_s = -10: must be a finite number > 0"},
           {"shev_oo_nomaps_sort1", {"vehicle.genset.generator.efficiency=\"high\""}, "must be a number"},
           {"one_flange_test", {"vehicle.flanges=3"}, "flanges = 3: must be 1 or 2"},
           {"one_flange_test", {"cycle=\"" + test::source_path("data/cycles/cycle_sort1.csv") + "\""},
            "has no driver: remove the cycle"},
           {"ev_sort1", {"vehicle.vehicle.mass_kg=1.8"}, "outside the plausible band", true},
           {"psecu2_nedc", {"vehicle.ice.input=\"torque\""}, "the built-in ECUs send icePowRef, not iceTauRef", true},
           {"psecu2_nedc", {"vehicle.ice.on_off=false"}, "MBecu2 stops the engine through iceON, which this engine ignores",
            true},
           {"evpm_sort1", {"vehicle.drive.speed_max_rad_s=100"}, "above the rating the drive cannot hold its torque", true},
           // a machine in p.u.: its own fields' problems, named as the file has them
           {"evam_pu_sort1", {"vehicle.drive.r1_pu=0"}, "drive.r1_pu = 0: must be a finite number > 0"},
       }) {
    expect_reader_rule(c);
  }
}

TEST(ReaderRules, EachBrokenFileOrOverrideIsNamed) {
  const fs::path d = scratch_dir("files");
  std::ofstream(d / "syntax.toml") << "solver = = 1\n";
  std::ofstream(d / "no_cycle.toml") << "vehicle = \"mbev\"\n";
  std::ofstream(d / "tank.toml") << "kind = \"tank\"\n";
  std::ofstream(d / "one_column.csv") << "speed_rad_s\n0\n100\n";
  // a segment with both a current and a power
  std::ofstream(d / "both.toml") << "extends = \"battery_rig_mbev\"\n[[profile]]\ncurrent_A = 1\npower_W = 2\nduration_s = 1\n";
  // a chain of 17 vehicle files (the limit is 16), the last one over psecu2
  for (int i = 0; i < 17; ++i) {
    std::ofstream(d / ("v" + std::to_string(i) + ".toml"))
        << "extends = \"" << (i < 16 ? (d / ("v" + std::to_string(i + 1) + ".toml")).string() : std::string("psecu2"))
        << "\"\n";
  }
  // a vehicle file with a required file missing: psecu2's without its sfc_map
  {
    std::ifstream in(test::source_path("vehicles/psecu2.toml"));
    std::ofstream out(d / "no_sfc.toml");
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("sfc_map", 0) == 0) continue;
      for (std::size_t at; (at = line.find("\"../data/")) != std::string::npos;) {
        line.replace(at, 9, "\"" + test::source_path("data/"));
      }
      out << line << "\n";
    }
  }
  const std::string nedc = test::source_path("data/cycles/cycle_nedc.csv");
  for (const ReaderCase& c : std::vector<ReaderCase>{
           {"/nonexistent/scenario.toml", {}, "/nonexistent/scenario.toml: cannot read: no such file"},
           {(d / "syntax.toml").string(), {}, (d / "syntax.toml").string() + ":1: TOML syntax: "},
           {"ev_sort1", {"novalue"}, "--set novalue: expected key=value, e.g. --set vehicle.battery.soc_initial=0.6"},
           {"ev_sort1", {"a b=1"}, "--set a b=1: cannot parse: "},
           {(d / "no_cycle.toml").string(), {}, "cycle: missing (a vehicle with a driver needs a cycle file)"},
           {"ev_sort1", {"vehicle_file=\"" + (d / "tank.toml").string() + "\""}, "kind = \"tank\": must be "},
           {"psecu2_nedc", {"vehicle.ice.torque_max_table=\"" + (d / "one_column.csv").string() + "\""},
            "header: expected two columns (x, y)"},
           {"battery_cc_discharge", {"vehicle_file=\"" + (d / "both.toml").string() + "\""},
            "give either current_A or power_W (> 0 discharge, < 0 charge)"},
           {"psecu2_nedc", {"vehicle_file=\"" + (d / "v0.toml").string() + "\""}, "more than 16 vehicle files extend each other"},
           {"psecu2_nedc", {"vehicle_file=\"" + (d / "no_sfc.toml").string() + "\"", "cycle=\"" + nedc + "\""},
            "sfc_map: missing (required file name)"},
       }) {
    expect_reader_rule(c);
  }
  // an embedding program's scenario name that names nothing (hil/run/simulation.hpp)
  std::vector<std::string> sim_errors;
  EXPECT_EQ(load_simulation("no_such_scenario", {}, SimulationOptions{}, sim_errors), nullptr);
  ASSERT_EQ(sim_errors.size(), 1u);
  EXPECT_EQ(sim_errors[0].rfind("no_such_scenario: ", 0), 0u) << sim_errors[0];
  // a cycle given as arrays (the Python module's): both the same length
  Scenario sc;
  std::vector<std::string> errors;
  CycleArrays arrays;
  arrays.time_s = {0.0, 1.0, 2.0};
  arrays.speed_m_s = {0.0, 1.0};
  EXPECT_FALSE(load_scenario_with_cycle(test::source_path("scenarios/ev_sort1.toml"), {}, arrays, sc, errors));
  EXPECT_TRUE(std::any_of(errors.begin(), errors.end(), [](const std::string& e) {
    return e.find("3 time stamps, 2 speeds: the two arrays must have the same length") != std::string::npos;
  })) << text_of(errors);
}

}  // namespace
}  // namespace ehpt::hil
