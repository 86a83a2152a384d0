// SPDX-License-Identifier: BSD-3-Clause
// Plant faults (docs/testing.md): the pack's constants under each kind, exact where a closed
// form exists (a short at standstill, R0 at the fault's first step, derating's clamp), the
// energy audit that stays closed across them, and their load-time rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "hil/config/config.hpp"
#include "hil/run/batch.hpp"
#include "hil/run/simulation.hpp"
#include "plant/battery_rc.hpp"
#include "plant/bev_plant.hpp"
#include "test_plants.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {
namespace {

plant::BatteryRcParams pack(int strings) {
  plant::BatteryRcParams p;
  p.cell_capacity_Ah = 20.0;
  p.cells_series = 96;
  p.strings_parallel = strings;
  return p;
}

TEST(BatteryHealth, EachKindScalesItsConstantsAndHealthyRestoresEveryBit) {
  plant::BatteryRc b(pack(4));
  const plant::BatteryRcConstants h = b.constants();
  b.set_health({.r0_gain = 2.0}, h.emf_initial_V, 0.0);
  EXPECT_EQ(b.constants().r0_Ohm, 2.0 * h.r0_Ohm);
  EXPECT_EQ(b.constants().c_batt_F, h.c_batt_F);
  b.set_health({.capacity_gain = 0.8}, h.emf_initial_V, 0.0);
  EXPECT_EQ(b.constants().c_batt_F, h.c_batt_F * 0.8);
  EXPECT_EQ(b.constants().r0_Ohm, h.r0_Ohm);
  b.set_health({.strings_lost = 1}, h.emf_initial_V, 0.0);  // 4 -> 3 strings
  EXPECT_DOUBLE_EQ(b.constants().c_batt_F, h.c_batt_F * 0.75);
  EXPECT_DOUBLE_EQ(b.constants().c1_F, h.c1_F * 0.75);
  EXPECT_DOUBLE_EQ(b.constants().r0_Ohm, h.r0_Ohm * 4.0 / 3.0);
  EXPECT_DOUBLE_EQ(b.constants().r1_Ohm, h.r1_Ohm * 4.0 / 3.0);
  EXPECT_DOUBLE_EQ(b.constants().current_max_A, h.current_max_A * 0.75);
  // one string of the healthy pack's voltage drop per string current: the same cell current
  const double e = 0.5 * (h.emf_min_V + h.emf_max_V);
  const plant::BatteryTerminal three = b.at_current(e, 0.0, 30.0);
  plant::BatteryRc healthy(pack(4));
  const plant::BatteryTerminal four = healthy.at_current(e, 0.0, 40.0);
  EXPECT_DOUBLE_EQ(e - three.voltage_V, e - four.voltage_V);
  // a short: its current in the main branch at no load, its loss behind R0
  b.set_health({.short_A = 5.0}, h.emf_initial_V, 0.0);
  const plant::BatteryTerminal s = b.at_current(e, 0.0, 0.0);
  EXPECT_EQ(s.main_A, 5.0);
  EXPECT_EQ(s.loss_W, e * 5.0);
  EXPECT_DOUBLE_EQ(b.demf_dt(s), -5.0 / h.c_batt_F);
  // back to healthy: the constants and a terminal() bit for bit as built
  b.set_health({}, h.emf_initial_V, 0.0);
  EXPECT_EQ(b.constants().r0_Ohm, h.r0_Ohm);
  EXPECT_EQ(b.constants().c_batt_F, h.c_batt_F);
  EXPECT_EQ(b.constants().current_max_A, h.current_max_A);
  const plant::BatteryTerminal t1 = b.terminal(e, 1.5, 20000.0), t2 = healthy.terminal(e, 1.5, 20000.0);
  EXPECT_EQ(t1.voltage_V, t2.voltage_V);
  EXPECT_EQ(t1.main_A, t2.main_A);
  EXPECT_EQ(t1.loss_W, t2.loss_W);
}

struct FaultedRun {
  MemoryRun rows;
  plant::EnergyAudit audit;
  std::size_t col(const std::string& name) const {
    const auto at = std::find(rows.columns.begin(), rows.columns.end(), name);
    EXPECT_NE(at, rows.columns.end()) << name;
    return static_cast<std::size_t>(at - rows.columns.begin());
  }
  double at(std::size_t row, const std::string& name) const { return rows.rows[row * rows.columns.size() + col(name)]; }
  std::size_t count() const { return rows.rows.size() / rows.columns.size(); }
};

FaultedRun run(const char* scenario, std::vector<std::string> sets, const std::vector<std::string>& faults) {
  Scenario sc;
  std::vector<std::string> errors;
  sets.push_back("output.decimation=1");
  EXPECT_TRUE(load_scenario(test::source_path(scenario), sets, faults, sc, errors)) << (errors.empty() ? "" : errors[0]);
  FaultedRun r;
  r.rows = run_in_memory(sc);
  auto sim = make_simulation(sc, {});
  while (!sim->finished()) sim->run();
  r.audit = sim->audit();
  return r;
}

double term(const plant::EnergyAudit& a, const std::string& name) {
  for (const auto& [k, v] : a.terms) {
    if (k == name) return v;
  }
  return std::nan("");
}

// NEDC stands still for its first 11 s: no load, so the EMF falls by exactly current_A t / C.
TEST(PlantFault, AnInternalShortDrainsThePackAtItsCurrentWhileTheCarStands) {
  const std::vector<std::string> sets = {"solver.duration_s=10"};
  const FaultedRun h = run("scenarios/ev_nedc.toml", sets, {});
  const FaultedRun f = run("scenarios/ev_nedc.toml", sets, {"kind=internal_short current_A=50 at_s=2"});
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), sets, sc, errors));
  const plant::BevPlant plant(sc.plant.get<plant::BevParams>());
  const double c_F = plant.battery().constants().c_batt_F;
  const std::size_t end = h.count() - 1;
  ASSERT_EQ(h.at(end, "speed_m_s"), 0.0);
  EXPECT_EQ(f.at(1999, "battery_emf_V"), h.at(1999, "battery_emf_V"));  // before: the same run
  EXPECT_EQ(f.at(2000, "faults_active"), 1.0);
  EXPECT_NEAR(h.at(end, "battery_emf_V") - f.at(end, "battery_emf_V"), 50.0 * 8.0 / c_F, 1e-9);
  EXPECT_GT(h.at(end, "battery_emf_V") - f.at(end, "battery_emf_V"), 1e-4);
  // the short's loss (E - v_rc) current_A is in the audit (v_rc charges to current_A R1), which closes
  const double e_i_t = 50.0 * 8.0 * h.at(end, "battery_emf_V");
  EXPECT_NEAR(f.audit.battery_loss_J - h.audit.battery_loss_J, e_i_t, 1e-3 * e_i_t);
  EXPECT_LT(std::abs(f.audit.residual_J), 1e-6 * f.audit.scale_J);
}

// R0 acts from the fault's first step: there the state is the healthy run's, and the drop
// behind R0 is twice the healthy one for the same power.
TEST(PlantFault, R0GainDoublesTheDropFromTheFaultsFirstStep) {
  const std::vector<std::string> sets = {"solver.duration_s=60"};
  const FaultedRun h = run("scenarios/ev_nedc.toml", sets, {});
  const FaultedRun f = run("scenarios/ev_nedc.toml", sets, {"kind=r0_gain gain=2 at_s=55"});
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), sets, sc, errors));
  const double r0 = plant::BevPlant(sc.plant.get<plant::BevParams>()).battery().constants().r0_Ohm;
  const std::size_t n = 55000;
  ASSERT_EQ(f.at(n - 1, "battery_voltage_V"), h.at(n - 1, "battery_voltage_V"));
  const double i_h = h.at(n, "battery_current_A"), i_f = f.at(n, "battery_current_A");
  ASSERT_GT(std::abs(i_h), 1.0);  // a load at 55 s (NEDC accelerates to 32 km/h)
  const double v_int = h.at(n, "battery_voltage_V") + r0 * i_h;  // E - v_rc, the same state
  ASSERT_GT(r0 * std::abs(i_f), 1e4 * 1e-9 * v_int);  // the drop is far above the tolerance
  EXPECT_NEAR(v_int - f.at(n, "battery_voltage_V"), 2.0 * r0 * i_f, 1e-9 * v_int);
  EXPECT_NEAR(f.at(n, "battery_power_W"), h.at(n, "battery_power_W"), 1e-6 * std::abs(h.at(n, "battery_power_W")));
  EXPECT_GT(f.audit.battery_loss_J, h.audit.battery_loss_J);
}

// A lost string and capacity fade shrink the capacitors: the SOC stays where it was at the
// change, moves faster after it, and the audit books what the capacitors lost.
TEST(PlantFault, StringLossAndCapacityFadeKeepTheSocAndTheAuditClosed) {
  const std::vector<std::string> sets = {"solver.duration_s=120", "vehicle.battery.strings_parallel=4"};
  const FaultedRun h = run("scenarios/ev_nedc.toml", sets, {});
  const FaultedRun f = run("scenarios/ev_nedc.toml", sets,
                    {"kind=string_loss strings=1 at_s=30", "kind=capacity_fade fraction=0.5 at_s=60 until_s=90"});
  const std::size_t a = 30000, end = h.count() - 1;
  EXPECT_EQ(f.at(a, "soc"), h.at(a, "soc"));  // no jump at the change
  const double used_h = h.at(a, "soc") - h.at(end, "soc"), used_f = f.at(a, "soc") - f.at(end, "soc");
  ASSERT_GT(used_h, 1e-4);
  EXPECT_GT(used_f, 1.2 * used_h);  // three strings of four carry it, half as big for 30 s
  const double removed = term(f.audit, "battery_removed_by_faults_J");
  EXPECT_GT(removed, 0.1 * f.audit.scale_J);  // large against what the run used ...
  EXPECT_LT(std::abs(f.audit.residual_J), 1e-6 * f.audit.scale_J);  // ... and the audit still closes
  EXPECT_TRUE(std::isnan(term(h.audit, "battery_removed_by_faults_J")));  // a healthy run has no such term
}

// Derating clamps the torque to gain x the drive's bound; the ECU reads the derated bound.
TEST(PlantFault, DerateClampsTheDriveAndTheEcuReadsTheDeratedBound) {
  const std::vector<std::string> sets = {"solver.duration_s=200"};
  const FaultedRun h = run("scenarios/ev_nedc.toml", sets, {});
  const FaultedRun f = run("scenarios/ev_nedc.toml", sets, {"kind=derate target=drive gain=0.25 at_s=0"});
  double cut = 0.0;
  for (std::size_t r = 0; r < f.count(); ++r) {
    const double bound = 0.25 * f.at(r, "drive_torque_limit_Nm");
    ASSERT_LE(std::abs(f.at(r, "drive_torque_Nm")), bound + 1e-12) << r;
    cut = std::max(cut, std::abs(h.at(r, "drive_torque_Nm")) - 0.25 * h.at(r, "drive_torque_limit_Nm"));
  }
  EXPECT_GT(cut, 1.0);  // the healthy drive went past the derated bound: the clamp acted
  // what an ECU outside reads
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=1"},
                            {"kind=derate target=drive gain=0.25 at_s=0.5"}, sc, errors));
  SimulationOptions opt;
  opt.external_ecu = true;
  auto sim = make_simulation(sc, opt);
  std::vector<double> lim;
  while (!sim->finished()) {
    msgs::EvSensors s;
    ASSERT_TRUE(sim->read_sensors(s));
    lim.push_back(s.driveTauLim_Nm);
    msgs::EvCommand c;
    c.stamp = s.stamp;
    sim->write_command(c);
    sim->step(10);
  }
  ASSERT_EQ(lim.size(), 101u);
  EXPECT_GT(lim[0], 0.0);
  EXPECT_EQ(lim[49], lim[0]);
  EXPECT_EQ(lim[50], 0.25 * lim[0]);
}

TEST(PlantFault, DerateOnAPsdMachineLowersItsLimitSignal) {
  const std::vector<std::string> sets = {"solver.duration_s=60", "output.signals=[\"time_s\", \"motTauLim_Nm\", "
                                                                 "\"mot_torque_Nm\", \"genTauLim_Nm\"]"};
  const FaultedRun h = run("scenarios/psecu2_nedc.toml", sets, {});
  const FaultedRun f = run("scenarios/psecu2_nedc.toml", sets, {"kind=derate target=mot gain=0.5 at_s=20"});
  for (std::size_t r = 0; r < f.count(); ++r) {
    if (r < 20000) {
      ASSERT_EQ(f.at(r, "motTauLim_Nm"), h.at(r, "motTauLim_Nm")) << r;
      continue;
    }
    ASSERT_LE(std::abs(f.at(r, "mot_torque_Nm")), f.at(r, "motTauLim_Nm") + 1e-12) << r;
  }
  EXPECT_EQ(f.at(20000, "motTauLim_Nm"), 0.5 * h.at(20000, "motTauLim_Nm"));
  EXPECT_EQ(f.at(20000, "genTauLim_Nm"), h.at(20000, "genTauLim_Nm"));  // the other machine untouched
  EXPECT_LT(std::abs(f.audit.residual_J), 1e-6 * f.audit.scale_J);
}

// --- rules (docs/validation-rules.md) ---

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / ("ehpt_plant_faults_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

bool any_error(const std::string& tables, const std::string& what, const char* base = "scenarios/ev_nedc.toml") {
  const fs::path file = temp_dir() / "t.toml";
  std::ofstream(file) << "scenario = \"" << test::source_path(base) << "\"\n[solver]\nduration_s = 3\n" << tables;
  Scenario sc;
  std::vector<std::string> errors;
  load_scenario(file.string(), {}, sc, errors);
  for (const auto& e : errors) {
    if (e.find(what) != std::string::npos && e.find("t.toml:") != std::string::npos) return true;
  }
  ADD_FAILURE() << "no error with \"" << what << "\" and its line; got " << (errors.empty() ? "none" : errors[0]);
  return false;
}

TEST(PlantFaultRules, EachImpossiblePlantFaultIsALoadErrorWithItsLine) {
  const std::string f = "[[fault]]\n";
  EXPECT_TRUE(any_error(f + "kind = \"r0_gain\"\ntarget = \"batSOC\"\ngain = 2\n", "acts on the pack: leave target out"));
  EXPECT_TRUE(any_error(f + "kind = \"gain\"\ntarget = \"battery\"\ngain = 2\n", "the pack's own faults are"));
  EXPECT_TRUE(any_error(f + "kind = \"derate\"\ngain = 0.5\n", "missing: the machine it derates"));
  EXPECT_TRUE(any_error(f + "kind = \"derate\"\ntarget = \"drve\"\ngain = 0.5\n", "not a machine of this vehicle; did you mean \"drive\""));
  EXPECT_TRUE(any_error(f + "kind = \"derate\"\ntarget = \"drive\"\ngain = 1.5\n", "gain = 1.5: must be in [0, 1]"));
  EXPECT_TRUE(any_error(f + "kind = \"r0_gain\"\ngain = 0\n", "gain = 0: must be a finite number > 0 (R0 x gain"));
  EXPECT_TRUE(any_error(f + "kind = \"capacity_fade\"\nfraction = 1\n", "fraction = 1: must be in (0, 1)"));
  EXPECT_TRUE(any_error(f + "kind = \"internal_short\"\ncurrent_A = -1\n", "current_A = -1: must be a finite current > 0 A"));
  EXPECT_TRUE(any_error(f + "kind = \"string_loss\"\nstrings = 0\n", "strings = 0: must be a whole number of parallel strings"));
  EXPECT_TRUE(any_error(f + "kind = \"string_loss\"\nstrings = 1\n", "at least one string must remain"));  // mbev: one string
  EXPECT_TRUE(any_error("[vehicle.battery]\nstrings_parallel = 3\n" + f + "kind = \"string_loss\"\nstrings = 1\n" + f +
                            "kind = \"string_loss\"\nstrings = 2\n",
                        "and the faults before lose 1"));
  EXPECT_TRUE(any_error(f + "kind = \"capacity_fade\"\nfraction = 0.2\n", "this one's plant takes no plant faults",
                        "scenarios/battery_cc_discharge.toml"));
  EXPECT_TRUE(any_error(f + "kind = \"derate\"\ntarget = \"drive\"\ngain = 0.2\n", "this one's plant takes no plant faults",
                        "scenarios/battery_cc_discharge.toml"));
  EXPECT_TRUE(any_error(f + "kind = \"capacity_fade\"\nfraction = 0.2\ngain = 3\n", "not a parameter of kind = \"capacity_fade\""));
}

TEST(PlantFaultRules, TheFaultTextTakesPlantKeysAndNamesTheClosestKey) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=3"},
                            {"kind=internal_short current_A=2 at_s=1"}, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=3"},
                             {"kind=internal_short curent_A=2"}, sc, errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("not a fault key; did you mean \"current_A\""), std::string::npos) << errors[0];
}

}  // namespace
}  // namespace ehpt::hil
