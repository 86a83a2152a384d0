#include "hil/config.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "hil/scenario.hpp"
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
  const auto& p = std::get<plant::BevParams>(sc.plant);
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
  const auto& p = std::get<plant::BevParams>(sc.plant);
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
  EXPECT_EQ(errors[0], "--set output.interval_s=-1: output.interval_s = -1: must be > 0 s");
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"output.decimation=10"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u);  // ev_sort1 gives interval_s already
  EXPECT_NE(errors[0].find("give either output.interval_s or output.decimation"), std::string::npos);
  errors.clear();
  EXPECT_FALSE(
      load_scenario(test::source_path("scenarios/ev_sort1.toml"), {"vehicle.driver.gain=abc"}, sc, errors));
  ASSERT_EQ(errors.size(), 1u) << errors[0] << " / " << errors.back();
  EXPECT_EQ(errors[0], "--set vehicle.driver.gain=abc: driver.gain = 'abc': must be a number");
}

}  // namespace
}  // namespace ehpt::hil
