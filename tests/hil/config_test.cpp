// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/config.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "hil/config/toml_guard.hpp"
#include "plant/bev_plant.hpp"
#include "plant/psd_plant.hpp"

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
  // keys as the user wrote them (--set vehicle.x is vehicle.x), an unknown one with the closest known key
  EXPECT_EQ(errors[1], "--set vehicle.drive.torqe_max_Nm=3: vehicle.drive.torqe_max_Nm: unknown key; did you mean "
                       "`vehicle.drive.torque_max_Nm`?");
  EXPECT_EQ(errors[2], "--set vehicle.vehicle.mass_kg=-5: vehicle.vehicle.mass_kg = -5: must be a finite number > 0");
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
  EXPECT_EQ(errors[0], "--set vehicle.driver.gain=abc: vehicle.driver.gain = 'abc': must be a number");
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
  EXPECT_EQ(errors[0], "--set vehicle.battery.cells_series=4294967396: vehicle.battery.cells_series = 4294967396: "
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

// ---- vehicles by name and by extension (issue 21) ------------------------------------------

namespace ehpt::hil {
namespace {

namespace fs = std::filesystem;

// A scratch folder of its own per test, removed at the end.
class VehicleFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_root() / ("config_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  std::string cycle(const std::string& name = "cycle_sort1.csv") const {
    return "cycle = \"" + test::source_path("data/cycles/" + name) + "\"\n";
  }
  // loads; returns the errors (empty: loaded)
  std::vector<std::string> load(const std::string& scenario, const std::vector<std::string>& sets = {}) {
    std::vector<std::string> errors;
    load_scenario(scenario, sets, sc_, errors);
    return errors;
  }
  static std::string all(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& e : v) s += e + "\n";
    return s;
  }
  fs::path dir_;
  Scenario sc_;
};

TEST_F(VehicleFiles, AShippedVehicleIsNamedFromAScenarioAnywhere) {
  const std::string s = write("s.toml", "vehicle = \"psecu2\"\n" + cycle("cycle_nedc.csv"));
  ASSERT_TRUE(load(s).empty()) << all(load(s));
  EXPECT_EQ(sc_.kind, "psd");
  EXPECT_EQ(fs::path(sc_.vehicle_path).filename(), "psecu2.toml");
  EXPECT_EQ(fs::weakly_canonical(sc_.vehicle_path), fs::weakly_canonical(test::source_path("vehicles/psecu2.toml")));
  // the same parameters as the shipped scenario that names the file by its path
  Scenario shipped;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {}, shipped, errors));
  EXPECT_EQ(sc_.plant.get<plant::PsdParams>().body.mass_kg, shipped.plant.get<plant::PsdParams>().body.mass_kg);
  EXPECT_EQ(sc_.inputs.size(), shipped.inputs.size());
  for (std::size_t i = 1; i < std::min(sc_.inputs.size(), shipped.inputs.size()); ++i) {
    EXPECT_EQ(sc_.inputs[i].sha256, shipped.inputs[i].sha256) << sc_.inputs[i].path;  // [0]: the scenarios differ
  }
  // and from --set, over a scenario that names a file
  ASSERT_TRUE(load(test::source_path("scenarios/ev_sort1.toml"), {"vehicle=evpm_bat", "vehicle_file=x"}).size() == 1u);
  ASSERT_TRUE(load(test::source_path("scenarios/ev_sort1.toml"), {"vehicle=evpm_bat"}).empty());
  EXPECT_EQ(sc_.kind, "ev_pm");
}

TEST_F(VehicleFiles, BothVehicleAndVehicleFileIsAnError) {
  const std::string s = write("s.toml", "vehicle = \"psecu2\"\nvehicle_file = \"" +
                                            test::source_path("vehicles/psecu2.toml") + "\"\n" + cycle());
  const auto errors = load(s);
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], s + ":1: vehicle = \"psecu2\": give either vehicle (a shipped vehicle's name) or vehicle_file "
                           "(a path), not both");
  const auto none = load(write("n.toml", cycle()));
  ASSERT_EQ(none.size(), 1u) << all(none);
  EXPECT_NE(none[0].find("vehicle: missing (name a shipped vehicle with vehicle = \"NAME\""), std::string::npos) << none[0];
}

TEST_F(VehicleFiles, AnUnknownNameListsTheShippedVehiclesAndSuggestsTheClosest) {
  const std::string s = write("s.toml", "vehicle = \"psceu2\"\n" + cycle());
  const auto errors = load(s);
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0].rfind(s + ":1: vehicle = \"psceu2\": no shipped vehicle of that name (in ", 0), 0u) << errors[0];
  EXPECT_NE(errors[0].find("the vehicles are battery_rig_mbev, evam_bat, evam_pu_bat, evpm_bat, mbev, psecu1, psecu1soc, "
                           "psecu2, shev_oo, shev_oo_nomaps, shev_power_filt, shev_power_filt_soc, test_am_drive"),
            std::string::npos)
      << errors[0];
  EXPECT_TRUE(errors[0].ends_with("; did you mean \"psecu2\"?")) << errors[0];
  // a path is not a name
  const auto path = load(write("p.toml", "vehicle = \"../vehicles/psecu2.toml\"\n" + cycle()));
  ASSERT_EQ(path.size(), 1u);
  EXPECT_NE(path[0].find("a name of a shipped vehicle, not a path; name a file of your own with vehicle_file"),
            std::string::npos)
      << path[0];
}

TEST_F(VehicleFiles, AVehicleFileExtendsAShippedOneAndOverridesAFewFields) {
  write("heavy.toml", "extends = \"psecu2\"\ndescription = \"PSecu2 at 1800 kg\"\n[vehicle]\nmass_kg = 1800.0\n");
  const std::string s = write("s.toml", "vehicle_file = \"heavy.toml\"\n" + cycle("cycle_nedc.csv"));
  ASSERT_TRUE(load(s).empty()) << all(load(s));
  EXPECT_EQ(sc_.kind, "psd");  // from the base
  const auto& p = sc_.plant.get<plant::PsdParams>();
  EXPECT_EQ(p.body.mass_kg, 1800.0);
  EXPECT_EQ(p.body.wheel_radius_m, 0.31);  // the base's
  EXPECT_EQ(p.ring_sun_ratio, 2.6);
  // provenance: every file read, the base included
  std::vector<std::string> names;
  for (const auto& f : sc_.inputs) names.push_back(fs::path(f.path).filename().string());
  ASSERT_GE(names.size(), 4u);
  EXPECT_EQ(names[0], "s.toml");
  EXPECT_EQ(names[1], "heavy.toml");
  EXPECT_EQ(names[2], "psecu2.toml");
  // a scenario's --set still wins over both
  ASSERT_TRUE(load(s, {"vehicle.vehicle.mass_kg=1500"}).empty());
  EXPECT_EQ(sc_.plant.get<plant::PsdParams>().body.mass_kg, 1500.0);
}

TEST_F(VehicleFiles, AChainOfExtendsPointsEachProblemAtTheFileThatGaveTheValue) {
  // top -> middle (by path) -> mbev (by name)
  const std::string middle = write("middle.toml", "extends = \"mbev\"\n[battery]\nsoc_initial = 1.5\n");
  const std::string top = write("top.toml", "extends = \"middle.toml\"\nkind = \"bev\"\n[vehicle]\nmass_kg = -3\n");
  const std::string s = write("s.toml", "vehicle_file = \"top.toml\"\n" + cycle());
  const auto errors = load(s);
  ASSERT_EQ(errors.size(), 2u) << all(errors);
  EXPECT_EQ(errors[0], top + ":4: vehicle.mass_kg = -3: must be a finite number > 0");
  EXPECT_EQ(errors[1].rfind(middle + ":3: battery.soc_initial = 1.5: must be in [", 0), 0u) << errors[1];
  std::vector<std::string> names;
  for (const auto& f : sc_.inputs) names.push_back(fs::path(f.path).filename().string());
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 4),
            (std::vector<std::string>{"s.toml", "top.toml", "middle.toml", "mbev.toml"}));
}

TEST_F(VehicleFiles, ACycleOfExtendsIsAnErrorNamingTheFiles) {
  const std::string a = write("a.toml", "extends = \"b.toml\"\n");
  const std::string b = write("b.toml", "extends = \"./a.toml\"\n");
  const auto errors = load(write("s.toml", "vehicle_file = \"a.toml\"\n" + cycle()));
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], b + ":1: extends = \"./a.toml\": the vehicle files extend each other in a cycle: " + a + " -> " + b +
                           " -> " + a);
  // a file extending itself
  const std::string self = write("self.toml", "extends = \"self.toml\"\n");
  const auto own = load(write("s2.toml", "vehicle_file = \"self.toml\"\n" + cycle()));
  ASSERT_EQ(own.size(), 1u);
  EXPECT_NE(own[0].find("in a cycle: " + self + " -> " + self), std::string::npos) << own[0];
}

TEST_F(VehicleFiles, AFileThatExtendsAnotherKeepsItsKind) {
  const std::string v = write("v.toml", "extends = \"psecu2\"\nkind = \"bev\"\n");
  const auto errors = load(write("s.toml", "vehicle_file = \"v.toml\"\n" + cycle()));
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0].rfind(v + ":2: kind = \"bev\": differs from kind = \"psd\" of ", 0), 0u) << errors[0];
  EXPECT_NE(errors[0].find("psecu2.toml, which it extends"), std::string::npos);
  // the same kind repeated is fine; an unknown base name is named with its line
  write("same.toml", "extends = \"psecu2\"\nkind = \"psd\"\n");
  EXPECT_TRUE(load(write("s2.toml", "vehicle_file = \"same.toml\"\n" + cycle("cycle_nedc.csv"))).empty());
  const std::string bad = write("bad.toml", "\nextends = \"psecu9\"\n");
  const auto unknown = load(write("s3.toml", "vehicle_file = \"bad.toml\"\n" + cycle()));
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0].rfind(bad + ":2: extends = \"psecu9\": no shipped vehicle of that name", 0), 0u) << unknown[0];
  // only a vehicle file extends: in a scenario it would be ignored silently
  const auto in_scenario = load(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.extends=psecu2"});
  ASSERT_EQ(in_scenario.size(), 1u);
  EXPECT_NE(in_scenario[0].find("vehicle.extends: only a vehicle file can extend another"), std::string::npos);
}

// ---- did you mean, keys as written -------------------------------------------------------

TEST_F(VehicleFiles, AMisplacedKeyGetsTheRightSpelling) {
  const std::string ev = test::source_path("scenarios/ev_sort1.toml");
  auto errors = load(ev, {"vehicle.mass_kg=1800"});
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], "--set vehicle.mass_kg=1800: vehicle.mass_kg: unknown key; did you mean `vehicle.vehicle.mass_kg`?");
  errors = load(ev, {"mass_kg=1800"});
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], "--set mass_kg=1800: mass_kg: unknown key; did you mean `vehicle.vehicle.mass_kg`?");
  errors = load(ev, {"vehicle.battery.capacity=5"});
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], "--set vehicle.battery.capacity=5: vehicle.battery.capacity: unknown key; did you mean "
                       "`vehicle.battery.cell_capacity_Ah`?");
  errors = load(ev, {"battery.soc_initial=0.5"});  // "vehicle." forgotten: the whole key is named
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], "--set battery.soc_initial=0.5: battery.soc_initial: unknown key; did you mean "
                       "`vehicle.battery.soc_initial`?");
  // the same key at the right depth wins over the same word in another table (ice, gen, mot)
  errors = load(test::source_path("scenarios/psecu2_nedc.toml"), {"mot.inertia_kgm2=1"});
  ASSERT_EQ(errors.size(), 1u) << all(errors);
  EXPECT_EQ(errors[0], "--set mot.inertia_kgm2=1: mot.inertia_kgm2: unknown key; did you mean `vehicle.mot.inertia_kgm2`?");
  errors = load(ev, {"step_s=0.002"});
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set step_s=0.002: step_s: unknown key; did you mean `solver.step_s`?");
  // nothing close: no hint
  errors = load(ev, {"vehicle.battery.zzzzzz=1"});
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set vehicle.battery.zzzzzz=1: vehicle.battery.zzzzzz: unknown key");
}

TEST_F(VehicleFiles, KeysAreNamedAsWrittenInTheScenarioAndInTheVehicleFile) {
  // a scenario's [vehicle] mass_kg and [vehicle.battery] typo, and a vehicle file's [battery] typo
  const std::string v = write("v.toml", "extends = \"mbev\"\n[battery]\ncapacity_Ah = 50\n");
  const std::string s = write("s.toml", "vehicle_file = \"v.toml\"\n" + cycle() +
                                            "[vehicle]\nmass_kg = 1800\n[vehicle.battery]\nsoc_initial = 2\n");
  const auto errors = load(s);
  ASSERT_EQ(errors.size(), 3u) << all(errors);
  EXPECT_EQ(errors[0], v + ":3: battery.capacity_Ah: unknown key; did you mean `battery.cell_capacity_Ah`?");
  EXPECT_EQ(errors[1], s + ":4: vehicle.mass_kg: unknown key; did you mean `vehicle.vehicle.mass_kg`?");
  EXPECT_EQ(errors[2].rfind(s + ":6: vehicle.battery.soc_initial = 2: must be in [", 0), 0u) << errors[2];
  // a scenario key in a vehicle file
  const std::string w = write("w.toml", "extends = \"mbev\"\n[solver]\nstep_s = 0.002\n");
  const auto wrong = load(write("s2.toml", "vehicle_file = \"w.toml\"\n" + cycle()));
  ASSERT_EQ(wrong.size(), 1u) << all(wrong);
  EXPECT_EQ(wrong[0], w + ":2: solver: unknown key; did you mean `solver` (a key of the scenario, not of the vehicle file)?");
}

// ---- plausibility warnings -----------------------------------------------------------------

std::vector<std::string> plausibility_warnings(const Scenario& sc) {
  std::vector<std::string> out;
  for (const auto& w : sc.warnings) {
    if (w.find("outside the plausible band") != std::string::npos) out.push_back(w);
  }
  return out;
}

TEST(Plausibility, NoShippedScenarioWarns) {
  const auto list = list_scenarios(test::source_path("scenarios"));
  ASSERT_GE(list.size(), 30u);
  for (const auto& s : list) {
    Scenario sc;
    std::vector<std::string> errors;
    ASSERT_TRUE(load_scenario(s.path, {}, sc, errors)) << s.name;
    EXPECT_TRUE(plausibility_warnings(sc).empty()) << s.name << ": " << plausibility_warnings(sc)[0];
  }
}

// One band: the warning just outside (naming the key as written and the band), none just inside.
struct BandCase {
  const char* scenario;
  const char* key;  // as --set writes it
  double lo, hi;
  bool integer = false;
};

void expect_band(const BandCase& b) {
  const auto warnings_at = [&](double value) {
    Scenario sc;
    std::vector<std::string> errors;
    std::string text = b.integer ? std::to_string(static_cast<long long>(value)) : plant::number_text(value);
    load_scenario(test::source_path(std::string("scenarios/") + b.scenario + ".toml"), {std::string(b.key) + "=" + text},
                  sc, errors);
    std::vector<std::string> mine;
    for (const auto& w : plausibility_warnings(sc)) {
      if (w.find(std::string(": ") + b.key + " = ") != std::string::npos) mine.push_back(w);
    }
    return mine;
  };
  const std::string band = "outside the plausible band [" + plant::number_text(b.lo) + ", " + plant::number_text(b.hi) + "]";
  const double below = b.integer ? b.lo - 1 : b.lo * 0.99, above = b.integer ? b.hi + 1 : b.hi * 1.01;
  if (below > 0) {
    const auto w = warnings_at(below);
    ASSERT_EQ(w.size(), 1u) << b.key << " = " << below;
    EXPECT_NE(w[0].find(band), std::string::npos) << w[0];
    EXPECT_EQ(w[0].rfind(std::string("--set ") + b.key + "=", 0), 0u) << w[0];
  }
  EXPECT_TRUE(warnings_at(b.lo).empty()) << b.key << " = " << b.lo;
  EXPECT_TRUE(warnings_at(b.hi).empty()) << b.key << " = " << b.hi;
  const auto w = warnings_at(above);
  ASSERT_EQ(w.size(), 1u) << b.key << " = " << above;
  EXPECT_NE(w[0].find(band), std::string::npos) << w[0];
}

TEST(Plausibility, EachBandWarnsJustOutsideAndNotJustInside) {
  for (const BandCase& b : std::initializer_list<BandCase>{
           {"ev_sort1", "vehicle.vehicle.mass_kg", 50.0, 60000.0},
           {"ev_sort1", "vehicle.vehicle.wheel_radius_m", 0.1, 1.5},
           {"ev_sort1", "vehicle.vehicle.gear_ratio", 0.2, 50.0},
           {"ev_sort1", "vehicle.battery.cell_capacity_Ah", 0.1, 1000.0},
           {"ev_sort1", "vehicle.battery.r0_cell_Ohm", 1e-5, 1.0},
           {"ev_sort1", "vehicle.battery.r1_cell_Ohm", 1e-5, 1.0},
           {"ev_sort1", "vehicle.battery.c1_cell_F", 1.0, 1e7},
           {"ev_sort1", "vehicle.battery.cells_series", 1, 1000, true},
           {"ev_sort1", "vehicle.battery.strings_parallel", 1, 1000, true},
           {"ev_sort1", "vehicle.road.frontal_area_m2", 0.3, 15.0},
           {"ev_sort1", "vehicle.road.drag_coefficient", 0.1, 1.5},
           {"ev_sort1", "vehicle.road.rolling_coefficient", 0.001, 0.05},
           {"ev_sort1", "vehicle.drive.torque_max_Nm", 1.0, 20000.0},
           {"ev_sort1", "vehicle.drive.power_max_W", 500.0, 2e6},
           {"ev_sort1", "vehicle.drive.speed_max_rad_s", 10.0, 5000.0},
           {"ev_sort1", "vehicle.drive.inertia_kgm2", 1e-4, 50.0},
           {"evpm_nedc", "vehicle.drive.U_max_rms_V", 5.0, 2000.0},
           {"evpm_nedc", "vehicle.drive.I_lim_rms_A", 1.0, 5000.0},
           {"evam_nedc", "vehicle.drive.U_base_rms_V", 5.0, 2000.0},
           {"evam_nedc", "vehicle.drive.I_max_rms_A", 1.0, 5000.0},
           {"psecu2_nedc", "vehicle.ice.inertia_kgm2", 1e-4, 50.0},
           {"psecu2_nedc", "vehicle.gen.torque_max_Nm", 1.0, 20000.0},
       }) {
    SCOPED_TRACE(b.key);
    expect_band(b);
  }
}

TEST_F(VehicleFiles, AnEnginesPeakTorqueOutsideItsBandWarns) {
  // the shipped curve (peak 98 N m) scaled: to 20 kN m exactly (inside), then beyond
  std::string curve = "speed_rad_s,max_torque_Nm\n100,80\n400,";
  const auto with_peak = [&](const std::string& peak) {
    write("t.csv", curve + peak + "\n");
    Scenario sc;
    std::vector<std::string> errors;
    load_scenario(test::source_path("scenarios/psecu2_nedc.toml"),
                  {"vehicle.ice.torque_max_table=\"" + (dir_ / "t.csv").string() + "\""}, sc, errors);
    return plausibility_warnings(sc);
  };
  EXPECT_TRUE(with_peak("20000").empty());
  const auto w = with_peak("20300");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("ice.torque_max = 20300 N m (its peak): outside the plausible band [1, 20000] N m"),
            std::string::npos)
      << w[0];
}

}  // namespace
}  // namespace ehpt::hil

// ---- validation rules without a test before (docs/validation-rules.md) -----------------------

namespace ehpt::hil {
namespace {

std::vector<std::string> ev_sort1_with(const std::vector<std::string>& sets, Scenario& sc) {
  std::vector<std::string> errors;
  load_scenario(test::source_path("scenarios/ev_sort1.toml"), sets, sc, errors);
  return errors;
}

TEST(ValidationRules, TheStepIsInZeroToOneSecond) {
  Scenario sc;
  for (const char* step : {"0", "-0.001", "1.5", "nan"}) {
    const auto errors = ev_sort1_with({std::string("solver.step_s=") + step}, sc);
    ASSERT_EQ(errors.size(), 1u) << step;
    EXPECT_NE(errors[0].find("solver.step_s = "), std::string::npos);
    EXPECT_NE(errors[0].find(": must be in (0, 1] s"), std::string::npos) << errors[0];
  }
  EXPECT_TRUE(ev_sort1_with({"solver.step_s=1", "solver.duration_s=150", "vehicle.ecu.period_s=0"}, sc).empty());
}

TEST(ValidationRules, ADurationThatIsNotAWholeNumberOfStepsWarnsWithTheEnd) {
  Scenario sc;
  ASSERT_TRUE(ev_sort1_with({"solver.duration_s=10.0004"}, sc).empty());
  EXPECT_EQ(sc.solver.steps, 10000);
  ASSERT_EQ(sc.warnings.size(), 1u);
  EXPECT_NE(sc.warnings[0].find("solver.duration_s = 10.0004: not a whole number of steps; the run ends at t = 10 s"),
            std::string::npos)
      << sc.warnings[0];
  ASSERT_TRUE(ev_sort1_with({"solver.duration_s=10"}, sc).empty());
  EXPECT_TRUE(sc.warnings.empty());
}

TEST(ValidationRules, DecimationIsAtLeastOne) {
  Scenario sc;
  for (const char* d : {"0", "-3"}) {
    const auto errors = ev_sort1_with({"output.interval_s=0.1", std::string("output.decimation=") + d}, sc);
    bool found = false;
    for (const auto& e : errors) found = found || e.find("output.decimation = " + std::string(d) + ": must be >= 1") != std::string::npos;
    EXPECT_TRUE(found) << d << ": " << (errors.empty() ? "" : errors.back());
  }
}

TEST(ValidationRules, AnEcuPeriodBelowHalfAStepIsRefused) {
  Scenario sc;
  const auto errors = ev_sort1_with({"vehicle.ecu.period_s=1e-13"}, sc);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "--set vehicle.ecu.period_s=1e-13: vehicle.ecu.period_s = 1e-13: must be > 0 (0: every step)");
  const auto latency = ev_sort1_with({"vehicle.ecu.latency_s=0.0015"}, sc);
  ASSERT_EQ(latency.size(), 1u);
  EXPECT_NE(latency[0].find("vehicle.ecu.latency_s = 0.0015: must be a whole multiple of solver.step_s = 0.001"),
            std::string::npos)
      << latency[0];
}

// The map and cycle readers' own checks (hil/config/config_reader.cpp), at the CSV's line.
class TableChecks : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_root() / ("tables_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::vector<std::string> with_map(const std::string& csv) {
    std::ofstream(dir_ / "m.csv") << csv;
    Scenario sc;
    return ev_sort1_with({"vehicle.drive.efficiency_map=\"" + (dir_ / "m.csv").string() + "\""}, sc);
  }
  std::vector<std::string> with_cycle(const std::string& csv) {
    std::ofstream(dir_ / "c.csv") << csv;
    Scenario sc;
    return ev_sort1_with({"cycle=\"" + (dir_ / "c.csv").string() + "\""}, sc);
  }
  std::string at(int line) const { return (dir_ / "m.csv").string() + ":" + std::to_string(line) + ": "; }
  std::filesystem::path dir_;
};

TEST_F(TableChecks, AMapIsAFullSortedGrid) {
  ASSERT_TRUE(with_map("t,w,eta\n0,0,0.9\n0,1,0.9\n1,0,0.9\n1,1,0.9\n").empty());
  // each check on its own (EXPECT: a planted defect in one shows which, the others still run)
  const auto only = [](const std::vector<std::string>& e) { return e.size() == 1u ? e[0] : "(" + std::to_string(e.size()) + " problems)"; };
  auto e = with_map("t,w,eta\n1,0,0.9\n1,1,0.9\n0,0,0.9\n0,1,0.9\n");
  EXPECT_EQ(only(e), at(4) + "drive.efficiency_map, column t = 0: row axis must be strictly increasing");
  e = with_map("t,w,eta\n0,1,0.9\n0,0,0.9\n1,1,0.9\n1,0,0.9\n");
  EXPECT_EQ(only(e), at(3) + "drive.efficiency_map, column w = 0: column axis must be strictly increasing");
  e = with_map("t,w,eta\n0,0,0.9\n0,1,0.9\n1,0,0.9\n");
  EXPECT_EQ(only(e), (dir_ / "m.csv").string() + ": drive.efficiency_map: 3 rows, a full 2 x 2 grid needs 4");
  e = with_map("t,w,eta\n0,0,0.9\n0,1,0.9\n1,1,0.9\n1,0,0.9\n");
  EXPECT_EQ(only(e), at(4) + "drive.efficiency_map: grid point out of order (rows must be sorted by the first column, "
                          "then the second)");
  e = with_map("t,eta\n0,0.9\n1,0.9\n");
  EXPECT_EQ(only(e), at(1) + "header: expected three columns (row axis, column axis, value)");
}

TEST_F(TableChecks, ACycleHasATimeAndASpeedColumn) {
  ASSERT_TRUE(with_cycle("time_s,speed_m_s\n0,0\n10,5\n").empty());
  const auto e = with_cycle("t,v\n0,0\n10,5\n");
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], (dir_ / "c.csv").string() + ":1: header: expected a time_s column and a speed_kmh or speed_m_s column "
                                              "(found t, v)");
}

}  // namespace
}  // namespace ehpt::hil

namespace ehpt::hil {
namespace {

// Rules of plant/ and ecu/ validate() that no test named before (found by grepping the tests
// for each field, then planting each defect): each refuses its value at load, named as set.
TEST(ValidationRules, EachRangeOfTheRigsDriversAndEcusIsCheckedAtLoad) {
  struct Case {
    const char* scenario;
    std::vector<std::string> sets;  // the last one is the bad value
  };
  for (const Case& c : std::initializer_list<Case>{
           {"one_flange_test", {"vehicle.request.start_s=-1"}},
           {"one_flange_test", {"vehicle.request.width_s=-1"}},
           {"one_flange_test", {"vehicle.request.falling_s=0"}},
           {"one_flange_test", {"vehicle.load.speed_initial_rad_s=nan"}},
           {"one_flange_test", {"vehicle.load.torque_nominal_Nm=inf"}},
           {"one_flange_test", {"vehicle.load.speed_nominal_rad_s=0"}},
           {"one_flange_test", {"vehicle.load.flange_a_torque_Nm=nan"}},
           {"one_flange_test", {"vehicle.dc_voltage_V=0"}},
           {"ev_sort1", {"vehicle.drive.limit_ramp_fraction=0"}},
           {"ev_sort1", {"vehicle.drive.limit_ramp_fraction=1.5"}},
           {"ev_sort1", {"vehicle.drive.loss_model=formula", "vehicle.drive.loss_formula.b_w=-1"}},
           {"ev_sort1", {"vehicle.drive.loss_model=formula", "vehicle.drive.loss_formula.b_p=-1"}},
           {"ev_sort1", {"vehicle.driver.request_max=0"}},
           {"ev_sort1", {"vehicle.driver.request_min=0.5"}},
           {"psecu2_nedc", {"vehicle.ice.speed_initial_rad_s=nan"}},
           {"psecu2_nedc", {"vehicle.ecu.max_torque_request_Nm=0"}},
           {"psecu2_nedc", {"vehicle.ecu.gen_loop_gain_Nm_s_rad=-1"}},
           {"psecu2_nedc", {"vehicle.ecu.gen_filter_s=0"}},
           {"psecu2_nedc", {"vehicle.ecu.gen_torque_max_Nm=0"}},
           {"psecu2_nedc", {"vehicle.ecu.ice_speed_min_rad_s=-1"}},
           {"psecu2_nedc", {"vehicle.ecu.ice_off_speed_ref_rad_s=-1"}},
       }) {
    const std::string& bad = c.sets.back();
    SCOPED_TRACE(bad);
    Scenario sc;
    std::vector<std::string> errors;
    EXPECT_FALSE(load_scenario(test::source_path(std::string("scenarios/") + c.scenario + ".toml"), c.sets, sc, errors));
    const std::string key = bad.substr(0, bad.find('='));
    EXPECT_EQ(errors.size(), 1u) << (errors.empty() ? "" : errors[0] + " / " + errors.back());
    if (errors.size() != 1u) continue;  // the other cases still run
    EXPECT_EQ(errors[0].rfind("--set " + bad + ": " + key + " = ", 0), 0u) << errors[0];
  }
}

}  // namespace
}  // namespace ehpt::hil
