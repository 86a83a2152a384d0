// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/config.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "hil/config/toml_guard.hpp"

#include "hil/config/scenario.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

TEST(Config, EveryShippedScenarioLoads) {
  const auto list = list_scenarios(test::source_path("scenarios"));
  ASSERT_GE(list.size(), 9u);
  for (const auto& s : list) {
    Scenario sc;
    std::vector<std::string> errors;
    EXPECT_TRUE(load_scenario(s.path, {}, sc, errors)) << s.name << ": " << (errors.empty() ? "" : errors[0]);
    EXPECT_GT(sc.solver.steps, 0) << s.name;
    EXPECT_FALSE(s.description.empty()) << s.name;
  }
}

TEST(Config, LoadsMbevWithUnitsConverted) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {}, sc, errors));
  const auto& p = sc.plant.get<plant::BevParams>();
  EXPECT_EQ(p.body.mass_kg, 1300.0);
  EXPECT_EQ(p.drive.loss_model, plant::DriveLossModel::kMap);
  EXPECT_EQ(sc.solver.duration_s, 1184.0);  // the cycle's end
  EXPECT_EQ(sc.solver.steps, 1184000);
  EXPECT_EQ(sc.output.decimation, 100);     // interval 0.1 s at 1 ms
  EXPECT_NEAR(p.driver.cycle_m_s(15.0), 15.0 / 3.6, 1e-12);  // km/h -> m/s
  EXPECT_NEAR(p.driver.cycle_m_s(19.0), 15.0 / 3.6, 1e-12);
}

TEST(Config, OverridesFromTheCommandLineWin) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"),
                            {"vehicle.battery.soc_initial=0.55", "solver.method=implicit-euler", "solver.step_s=0.002",
                             "cycle=\"" + test::source_path("data/cycles/cycle_udds.csv") + "\""},
                            sc, errors))
      << errors[0];
  const auto& p = sc.plant.get<plant::BevParams>();
  EXPECT_EQ(p.battery.soc_initial, 0.55);
  EXPECT_EQ(sc.solver.kind, SolverKind::kImplicitEuler);
  EXPECT_EQ(sc.solver.step_s, 0.002);
  EXPECT_EQ(sc.solver.duration_s, 1369.0);  // UDDS in m/s columns
}

TEST(Config, ProblemsNameWhereTheValueCameFrom) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_sort1.toml"),
                             {"vehicle.vehicle.mass_kg=-5", "vehicle.drive.torqe_max_Nm=3", "solver.method=euler"}, sc,
                             errors));
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_EQ(errors[0], "--set solver.method=euler: solver.method = \"euler\": must be \"rk4\" or \"implicit-euler\"");
  EXPECT_EQ(errors[1], "--set vehicle.drive.torqe_max_Nm=3: drive.torqe_max_Nm: unknown key");
  EXPECT_EQ(errors[2], "--set vehicle.vehicle.mass_kg=-5: vehicle.mass_kg = -5: must be a finite number > 0");
}

TEST(Config, OutputIntervalAndDecimationAreCheckedAndEachProblemReportedOnce) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"output.interval_s=-1"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set output.interval_s=-1: output.interval_s = -1: must be a finite number > 0 s");
  errors.clear();
  // ev_sort1 gives interval_s: a --set decimation wins over it, with a warning
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"output.decimation=10"}, sc, errors));
  EXPECT_EQ(sc.output.decimation, 10);
  ASSERT_EQ(sc.warnings.size(), 1u);
  EXPECT_NE(sc.warnings[0].find("output.interval_s: ignored: output.decimation is given by --set output.decimation=10"),
            std::string::npos)
      << sc.warnings[0];
  // and a --set interval wins over a decimation given by --set earlier? No: same layer kind,
  // different layers; the last --set is the highest
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"),
                            {"output.decimation=10", "output.interval_s=0.05"}, sc, errors));
  EXPECT_EQ(sc.output.decimation, 50);
  // both in one file is an error
  const auto dir = ehpt::test::scratch_root() / "config_both";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "s.toml") << "vehicle_file = \"" << test::source_path("vehicles/mbev.toml") << "\"\ncycle = \""
                                << test::source_path("data/cycles/cycle_sort1.csv")
                                << "\"\n[output]\ninterval_s = 0.1\ndecimation = 10\n";
  EXPECT_FALSE(load_scenario((dir / "s.toml").string(), {}, sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("give either output.interval_s or output.decimation"), std::string::npos);
  std::filesystem::remove_all(dir);
  errors.clear();
  EXPECT_FALSE(
      load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.driver.gain=abc"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u) << errors[0] << " / " << errors.back();
  EXPECT_EQ(errors[0], "--set vehicle.driver.gain=abc: driver.gain = 'abc': must be a number");
}

// Loads ev_sort1 with the overrides; returns the problems (empty: loaded).
std::vector<std::string> problems_with(const std::vector<std::string>& sets, Scenario& sc) {
  std::vector<std::string> errors;
  load_scenario(test::source_path("scenarios/ev_sort1.toml"), sets, sc, errors);
  return errors;
}

TEST(Config, StepCountsAreCheckedBeforeTheyAreRounded) {
  Scenario sc;
  // each of these ran 0 steps (or ~1e15) and reported "ok" before
  for (const char* set : {"solver.step_s=1e-300", "solver.step_s=1e-18", "solver.duration_s=1e308",
                          "solver.duration_s=1e-9", "solver.duration_s=1e12"}) {
    const auto errors = problems_with({set}, sc);
    ASSERT_EQ(errors.size(), 1u) << set;
    EXPECT_EQ(errors[0].rfind(std::string("--set ") + set + ": ", 0), 0u) << errors[0];
  }
  EXPECT_NE(problems_with({"solver.duration_s=1e-9"}, sc)[0].find("the run would have no step"), std::string::npos);
  EXPECT_NE(problems_with({"solver.duration_s=1e12"}, sc)[0].find("1e+15 steps, more than the limit of 1e10"),
            std::string::npos);
  // the step is blamed when the duration is the cycle's
  EXPECT_NE(problems_with({"solver.step_s=1e-18"}, sc)[0].find("solver.step_s = 1e-18: over the default duration of "
                                                               "150 s that is 1.5e+20 steps"),
            std::string::npos);
  // at the bound: 1e10 steps is allowed, one more is not
  ASSERT_TRUE(problems_with({"solver.step_s=1e-6", "solver.duration_s=10000"}, sc).empty());
  EXPECT_EQ(sc.solver.steps, kMaxSteps);
  EXPECT_EQ(problems_with({"solver.step_s=1e-6", "solver.duration_s=10000.001"}, sc).size(), 1u);
}

TEST(Config, AnIntervalLongerThanTheRunWritesTheFirstAndLastRowsOnly) {
  Scenario sc;
  ASSERT_TRUE(problems_with({"output.interval_s=1e30"}, sc).empty());
  EXPECT_EQ(sc.output.decimation, sc.solver.steps);  // was: llround overflowed, every step written
  ASSERT_TRUE(problems_with({"output.interval_s=0.02"}, sc).empty());
  EXPECT_EQ(sc.output.decimation, 20);
  ASSERT_TRUE(problems_with({"output.interval_s=1e-6"}, sc).empty());
  EXPECT_EQ(sc.output.decimation, 1);
  ASSERT_EQ(sc.warnings.size(), 1u);
  EXPECT_NE(sc.warnings[0].find("shorter than the step (0.001 s): every step is written"), std::string::npos);
}

TEST(Config, IntegersAreRangeCheckedBeforeNarrowingAndPrintedAsWritten) {
  Scenario sc;
  const auto errors = problems_with({"vehicle.battery.cells_series=4294967396"}, sc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set vehicle.battery.cells_series=4294967396: battery.cells_series = 4294967396: "
                       "must be a whole number in [1, 100000]");
  EXPECT_EQ(problems_with({"vehicle.battery.strings_parallel=0"}, sc).size(), 1u);
  EXPECT_EQ(problems_with({"vehicle.battery.strings_parallel=1.5"}, sc).size(), 1u);
  ASSERT_TRUE(problems_with({"vehicle.battery.cells_series=100000"}, sc).empty());
  EXPECT_EQ(sc.plant.get<plant::BevParams>().battery.cells_series, 100000);
}

TEST(Config, TheLastSetOfAKeyWins) {
  Scenario sc;
  ASSERT_TRUE(problems_with({"vehicle.vehicle.mass_kg=1000", "vehicle.vehicle.mass_kg=1500"}, sc).empty());
  EXPECT_EQ(sc.plant.get<plant::BevParams>().body.mass_kg, 1500.0);
  ASSERT_TRUE(problems_with({"solver.step_s=0.002", "solver.step_s=0.0005"}, sc).empty());
  EXPECT_EQ(sc.solver.step_s, 0.0005);
}

TEST(Config, OneSetIsOneKeyALineBreakIsRefused) {
  Scenario sc;
  const auto errors = problems_with({"solver.duration_s=10\nsolver.step_s=0.5"}, sc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set solver.duration_s=10...: one key=value per --set; the text holds a line break");
  EXPECT_EQ(problems_with({"vehicle.name=a\r"}, sc).size(), 1u);
  ASSERT_TRUE(problems_with({"solver.duration_s=10"}, sc).empty());
  EXPECT_EQ(sc.solver.duration_s, 10.0);
}

TEST(Config, ACoastingCarHasGainZero) {
  Scenario sc;
  ASSERT_TRUE(problems_with({"vehicle.driver.gain=0"}, sc).empty());
  EXPECT_EQ(sc.plant.get<plant::BevParams>().driver.gain, 0.0);
  EXPECT_EQ(problems_with({"vehicle.driver.gain=-1"}, sc).size(), 1u);
}

TEST(Config, RoadFormCanBeSwitchedWithSetAndTheOtherKeysAreIgnoredWithAWarning) {
  Scenario sc;
  ASSERT_TRUE(problems_with({"vehicle.road.form=coast-down", "vehicle.road.f0_N=150", "vehicle.road.f2_N_s2_m2=0.4"},
                            sc)
                  .empty());
  const auto& road = sc.plant.get<plant::BevParams>().road;
  EXPECT_EQ(road.form, plant::RoadLoadForm::kCoastDown);
  EXPECT_EQ(road.f0_N, 150.0);
  EXPECT_EQ(road.f2_N_s2_m2, 0.4);
  int ignored = 0;
  for (const auto& w : sc.warnings) ignored += w.find("ignored: road.form is \"coast-down\"") != std::string::npos;
  EXPECT_EQ(ignored, 4) << (sc.warnings.empty() ? "" : sc.warnings[0]);  // fc, rho, S, Cx of mbev.toml
  // the coast-down keys are still required
  EXPECT_EQ(problems_with({"vehicle.road.form=coast-down"}, sc).size(), 2u);
}

// Found by tests/fuzz: toml++ recurses once per dotted-key part, so a 62 kB key overflowed
// the stack (SIGSEGV). Every form of such a key is refused before toml++ sees it.
TEST(Config, AKeyWithThousandsOfDottedPartsIsRefusedNotACrash) {
  std::string deep = "a", digits = "0";
  for (int i = 0; i < 40000; ++i) {
    deep += ".b";
    digits += ".0";
  }
  Scenario sc;
  const auto errors = problems_with({deep + "=1"}, sc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("more than 1000 dots on one line"), std::string::npos) << errors[0].substr(0, 200);
  // a --set whose value brings a header on a second line
  EXPECT_EQ(problems_with({"description=1\n[" + digits + "]"}, sc).size(), 1u);
  const auto dir = ehpt::test::scratch_root() / "config_deep_key";
  std::filesystem::create_directories(dir);
  const std::string vehicle = (dir / "v.toml").string(), scenario = (dir / "s.toml").string();
  std::ofstream(scenario) << "vehicle_file = \"v.toml\"\ncycle = \"" << test::source_path("data/cycles/cycle_sort1.csv")
                          << "\"\n";
  // headers with bare keys of any kind, an array of tables, a key inside an inline table
  for (const std::string& line : {"[" + deep + "]", "[ " + digits + " ]", "[[" + digits + "]]",
                                  "x = { " + deep + " = 1 }"}) {
    std::ofstream(vehicle) << "kind = \"bev\"\n" << line << "\nx = 1\n";
    std::vector<std::string> errs;
    EXPECT_FALSE(load_scenario(scenario, {}, sc, errs));
    ASSERT_EQ(errs.size(), 1u);
    EXPECT_EQ(errs[0], vehicle + ":2: more than 1000 dots on one line (a dotted key that long would overflow the "
                                 "TOML parser; write a long array of numbers over several lines)");
  }
  std::filesystem::remove_all(dir);
  // ordinary text passes; the limit is per line
  EXPECT_EQ(line_with_too_many_dots("a.b.c = 1\n[x.y]\nv = [1.5, 2.5]\n"), 0);
  EXPECT_EQ(line_with_too_many_dots(std::string(1000, '.') + "\n" + std::string(1000, '.')), 0);
  EXPECT_EQ(line_with_too_many_dots("x\n" + std::string(1001, '.')), 2);
}

TEST(Config, TheBrakeSignalAfterTheRotorInertiaIsCheckedAtLoad) {
  Scenario sc;
  std::vector<std::string> errors;
  // gain G r = 3.43 N/Nm times J G/r: 36 J kg, above the 1300 kg car for J = 40 kg m^2 (no
  // unique solution of the brake's algebraic loop)
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_tutorial_nedc.toml"), {"vehicle.drive.inertia_kgm2=40"},
                             sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("brake.after_rotor_inertia = true: the brake gain times the reflected rotor inertia (1440.0000000000002 kg) "
                           "must be below vehicle.mass_kg"),
            std::string::npos)
      << errors[0];
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {"vehicle.brake.after_rotor_inertia=true"},
                             sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("only the map-based EV (kind = \"bev\") has this option"), std::string::npos) << errors[0];
}

}  // namespace
}  // namespace ehpt::hil

namespace ehpt::hil {
namespace {

TEST(Config, TheEcuRunsAtTheBusCycleTimeUnlessToldOtherwise) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {}, sc, errors));
  EXPECT_EQ(sc.solver.ecu_ratio, 10);  // 10 ms at h = 1 ms (io/can/ehpt.dbc's cycle time)
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {}, sc, errors));
  EXPECT_EQ(sc.solver.ecu_ratio, 10);
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.ecu.period_s=0"}, sc, errors));
  EXPECT_EQ(sc.solver.ecu_ratio, 1);  // 0: every step, as before
  // a step that does not divide the default: the message says what to set
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"solver.step_s=0.003"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("ecu.period_s = 0.01: the default ECU period (the bus cycle time) is not a whole multiple "
                           "of solver.step_s = 0.003; set vehicle.ecu.period_s"),
            std::string::npos)
      << errors[0];
  errors.clear();
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"),
                            {"solver.step_s=0.003", "vehicle.ecu.period_s=0.009"}, sc, errors));
  EXPECT_EQ(sc.solver.ecu_ratio, 3);
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.ecu.codec=lcm"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("ecu.codec = \"lcm\": must be \"none\" or \"can\""), std::string::npos) << errors[0];
  errors.clear();
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.ecu.codec=can"}, sc, errors));
  EXPECT_EQ(sc.ecu_codec, EcuCodec::kCan);
}

}  // namespace
}  // namespace ehpt::hil
